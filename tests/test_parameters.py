"""Scene parameters: -D name=value replaces $name in attribute
values, the scene's <default> fills in what is not given, the parameters
applied are part of the render's identity, and mistakes are named."""
import json
import math

import numpy as np

from conftest import read_full, run

SCENE = """<scene><camera position="0 0 5" lookat="0 0 0" fov="40" width="48" height="48"/>
<default name="r" value="0.5"/><default name="shade" value="unlit"/>
<object><sphere radius="$r" color="1 1 1"/><material shading="$shade"/></object></scene>"""


def render(tmp_path, name, *args):
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE)
    out = tmp_path / name
    proc = run([scene, "-o", out, "--sampler", "sobol", "--spp", 16, "--tspp", 1, "--quiet", *args])
    return proc, out


def test_parameters_replace_defaults_and_enter_the_identity(tmp_path):
    proc, small = render(tmp_path, "small.exr")
    assert proc.returncode == 0, proc.stderr
    proc, big = render(tmp_path, "big.exr", "-D", "r=0.8")
    assert proc.returncode == 0, proc.stderr
    a_small, h_small = read_full(small)
    a_big, h_big = read_full(big)
    assert h_small["refrender:parameters"] == "r=0.5 shade=unlit"
    assert h_big["refrender:parameters"] == "r=0.8 shade=unlit"
    # covered area grows as the projected radius squared (perspective: r / sqrt(d^2 - r^2))
    proj = lambda r: r / math.sqrt(25 - r * r)  # noqa: E731
    ratio = a_big["A"].sum() / a_small["A"].sum()
    assert abs(ratio - (proj(0.8) / proj(0.5)) ** 2) < 0.03 * ratio
    p0, _ = render(tmp_path, "p0.exr", "-D", "r=0.8", "--batches", 2, "--pass", "0/2")
    p1, _ = render(tmp_path, "p1.exr", "--batches", 2, "--pass", "1/2")
    assert p0.returncode == 0 and p1.returncode == 0
    merged = run(["merge", tmp_path / "p0.exr", tmp_path / "p1.exr", "-o", tmp_path / "m.exr"])
    assert merged.returncode == 1 and "refrender:parameters" in merged.stderr


def test_parameter_mistakes_are_named(tmp_path):
    scene = tmp_path / "u.xml"
    scene.write_text('<scene>\n<object><sphere radius="$size"/></object></scene>')
    unknown = run([scene, "-o", tmp_path / "x.exr"])
    assert unknown.returncode == 1 and "u.xml:2" in unknown.stderr and "$size" in unknown.stderr
    bad = run([scene, "-D", "2x=1", "-o", tmp_path / "x.exr"])
    assert bad.returncode == 2 and "parameter name" in bad.stderr
    proc, _ = render(tmp_path, "w.exr", "-D", "unused=3")
    assert proc.returncode == 0 and "parameter 'unused'" in proc.stderr and "not used" in proc.stderr
    assert not np.isnan(read_full(tmp_path / "w.exr")[0]["A"]).any()


def test_substituted_attributes_grow_and_long_values_are_named(tmp_path):
    """An attribute is whole after substitution however
    long (it was refused past 8191 characters): a weight table whose pairs
    are separated by a 500-character parameter of spaces, 20 times, reads
    all 21 pairs; a -D value past its 511 characters is refused naming its
    length."""
    pairs = " $gap ".join(f"{i / 20} {1 + i}" for i in range(21))
    scene = tmp_path / "t.xml"
    scene.write_text(f"""<scene><camera position="0 0 5" lookat="0 0 0" width="4" height="4"/>
<shutter open="0" close="1" weight="table" table="{pairs}"/><object><sphere radius="0.5"/></object></scene>""")
    proc = run(["export", scene, "-D", "gap=" + " " * 500, "-o", tmp_path / "t.json"])
    assert proc.returncode == 0, proc.stderr
    table = json.loads((tmp_path / "t.json").read_text())["frames"][0]["weight"]["table"]
    assert len(table) == 21 and table[-1] == [1.0, 21.0]
    proc = run(["export", scene, "-D", "gap=" + " " * 600, "-o", tmp_path / "t.json"])
    assert proc.returncode == 2 and "'gap': its value is 600 characters long: at most 511" in proc.stderr, proc.stderr
