"""Values Embree's float rays cannot reach (a camera at
1e19, a velocity of 1e19, a shutter of +-1e300 on a moving scene) once
aborted the render inside Embree (SIGABRT on its ray.valid() assertion).
They are refused before rendering, naming the scene and what is too far."""
import pytest

from conftest import run

SCENE = """<scene><camera position="0 0 {z}" lookat="0 0 0" width="4" height="4"/>
<object name="plate"><pointModel generate="plane" count="100" radius="1"/>
<animation><linear velocity="{v} 0 0"/></animation></object></scene>"""


@pytest.mark.parametrize("z, v, extra, what", [
    ("1e19", "1", [], "the camera reaches 1e+19"),
    ("5", "1e19", [], "object 'plate' reaches"),
    ("5", "1", ["--shutter", "-1e300,1e300"], "object 'plate' reaches"),
])
def test_out_of_reach_scenes_are_refused(tmp_path, z, v, extra, what):
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE.format(z=z, v=v))
    for mode in (["--spp", 1, "--tspp", 2], ["--time-integration", "exact", "--spp", 1]):
        proc = run([scene, *mode, *extra, "-o", tmp_path / "o.exr", "--quiet"])
        assert proc.returncode == 1, proc.stderr
        assert what in proc.stderr and "rays can only be traced within 1e+15" in proc.stderr
        assert not (tmp_path / "o.exr").exists()


def test_far_but_reachable_scenes_still_render(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE.format(z="1e6", v="1"))
    proc = run([scene, "--spp", 1, "--tspp", 2, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode == 0, proc.stderr


def test_a_shutter_with_more_key_times_than_bounds_can_list_is_refused(tmp_path):
    """Swept bounds list every key time where a step may
    jump; past 2^24 of them (a cycling curve over a long shutter) the render
    is refused, naming the object, rather than bounded from a cut list."""
    scene = tmp_path / "s.xml"
    scene.write_text("""<scene><camera position="0 0 5" lookat="0 0 0" width="4" height="4"/>
<shutter open="0" close="1e9"/><object name="ticker"><sphere radius="0.5"/><animation>
<keyframes interpolation="step" post="cycleRelative"><key time="0" translate="0 0 0"/>
<key time="1" translate="0.001 0 0"/></keyframes></animation></object></scene>""")
    proc = run([scene, "--spp", 1, "--tspp", 2, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode == 1 and "object 'ticker'" in proc.stderr and "key times" in proc.stderr, proc.stderr
