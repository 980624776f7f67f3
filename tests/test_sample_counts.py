"""End to end: sample counts past an int are refused before anything is
rendered or allocated, naming the counts; Sobol' batches have no end, as
each is its own scramble of the sequence's first points."""
from conftest import run

SCENE = """<scene><camera position="0 0 5" lookat="0 0 0" width="1" height="1"/>
<object><sphere center="0 0 0" radius="1"/></object></scene>"""


def test_counts_past_an_int_are_refused(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE)
    proc = run([scene, "--spp", 4096, "--tspp", 1000000, "--time-factor", 1, "-o", tmp_path / "o.exr"])
    assert proc.returncode == 1 and "4096000000 samples per batch" in proc.stderr, proc.stderr
    assert not (tmp_path / "o.exr").exists()


def test_sobol_batches_past_what_one_sequence_held_render(tmp_path):
    # batch 4099 of 2^20 samples: indices past 2^32 when batches were blocks of one sequence
    # (refused then); each batch is its own scramble of the first 2^20 points now
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE)
    proc = run([scene, "--sampler", "sobol", "--spp", 4, "--tspp", 1 << 18, "--batches", 4100,
                "--pass", "4099/4100", "--quiet", "-o", tmp_path / "p.exr"])
    assert proc.returncode == 0, proc.stderr
