"""Statistical regression tests of the scene suite: a fast render of every
scene in scenes/ with another seed must be consistent with its committed
reference in reference_images/ (criteria in scripts/regress.py), and the
check must reject renders with a deliberately broken feature."""
import pytest
import regress

from conftest import ROOT, run

# The suite is listed once, in the Makefile (SUITE, which `make references`
# renders): here it is every committed reference.
SUITE = sorted(p.stem for p in (ROOT / "reference_images").glob("*.exr"))
FAST = ["--spp", 4, "--tspp", 4, "--batches", 8, "--seed", 101, "--quiet"]


def fast_render(tmp_path, scene, *extra, name="test.exr"):
    out = tmp_path / name
    proc = run([scene, *FAST, *extra, "-o", out])
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.parametrize("name", SUITE)
def test_fast_render_agrees_with_the_reference(tmp_path, name):
    reference = ROOT / "reference_images" / f"{name}.exr"
    result = regress.check(reference, fast_render(tmp_path, ROOT / "scenes" / f"{name}.xml"))
    assert result["ok"], result


def test_the_check_rejects_broken_blending_and_weighting(tmp_path):
    # blending beyond the front surface (epsilon 1 instead of 0.01)
    broken = fast_render(tmp_path, ROOT / "scenes" / "diagonal.xml", "--eps", 1, name="eps.exr")
    assert not regress.check(ROOT / "reference_images" / "diagonal.exr", broken)["ok"]
    # the a(t) weighting ignored: box instead of linear
    box = (ROOT / "scenes" / "sphere_weights_linear.xml").read_text().replace('weight="linear"', 'weight="box"')
    scene = tmp_path / "sphere_weights_linear.xml"
    scene.write_text(box.replace(">models/", f">{ROOT / 'scenes' / 'models'}/"))
    broken = fast_render(tmp_path, scene, name="box.exr")
    assert not regress.check(ROOT / "reference_images" / "sphere_weights_linear.exr", broken)["ok"]


def test_every_suite_scene_has_a_reference_with_its_command():
    for name in SUITE:
        ref = ROOT / "reference_images" / f"{name}.exr"
        assert ref.exists(), ref
        assert ref.stat().st_size < 3_000_000
    total = sum(p.stat().st_size for p in (ROOT / "reference_images").iterdir())
    assert total < 30_000_000
    readme = (ROOT / "reference_images" / "README.md").read_text()
    for name in SUITE:
        assert f"scenes/{name}.xml" in readme
