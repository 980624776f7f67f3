"""refrender export (issue 15): a script with no refrender code projects a
disc's model-space center with the exported matrices, object to world to
camera to raster, and finds it where refrender renders it (the centroid of
its coverage) within 0.1 pixel: for a still scene, a keyframed object and a
moving camera. The shutter is 1e-7 long, so the exported time is the
rendered one."""
import json

import numpy as np
import pytest

from conftest import coverage_centroid, read_full, run

CAMERA = '<camera position="0.4 0.3 4" lookat="0 0 0" up="0 1 0" fov="40" width="96" height="64"{anim}'
STILL = "/>"
MOVING = ('><animation><keyframes interpolation="spline"><key time="0" translate="0 0 0" rotate="0 0 0"/>'
          '<key time="1" translate="-0.5 0.2 0.3" rotate="5 12 3"/></keyframes></animation></camera>')
DISC = ('<object name="disc" position="0.2 -0.1 0.3"><pointModel><splat center="{c}" normal="{n}" radius="0.08"/>'
        '</pointModel><material shading="unlit"/>{anim}</object>')
KEYED = ('<animation><keyframes interpolation="spline" pivot="0 0 0"><key time="0" translate="0 0 0" rotate="0 0 0"/>'
         '<key time="1" translate="0.6 0.3 -0.4" rotate="20 40 10"/></keyframes></animation>')


def scene_text(camera, disc_anim, center="0.5 0.3 0.1", normal="0.1 0.1 1"):
    return (f'<scene>{CAMERA.format(anim=camera)}<shutter open="0.4" close="0.4000001"/>'
            f'{DISC.format(c=center, n=normal, anim=disc_anim)}</scene>')


def project(data, point):
    frame = data["frames"][0]
    o2w = np.asarray(frame["object_to_world"]["disc"][0])
    w2c = np.asarray(frame["world_to_camera"][0])
    c2r = np.asarray(data["camera"]["camera_to_raster"])
    x, y, _, w = c2r @ w2c @ o2w @ np.array([*point, 1.0])
    return x / w, y / w


def test_exported_matrices_reproject_onto_the_render(tmp_path):
    cases = {"still": (STILL, ""), "keyframed": (STILL, KEYED), "moving_camera": (MOVING, ""),
             "both": (MOVING, KEYED)}
    for name, (camera, anim) in cases.items():
        scene = tmp_path / f"{name}.xml"
        scene.write_text(scene_text(camera, anim))
        js, exr = tmp_path / f"{name}.json", tmp_path / f"{name}.exr"
        assert run(["export", scene, "--times", 2, "-o", js]).returncode == 0
        assert run([scene, "-o", exr, "--sampler", "sobol", "--spp", 64, "--tspp", 1, "--quiet"]).returncode == 0
        data = json.loads(js.read_text())
        assert data["frames"][0]["times"][0] == 0.4 and len(data["frames"][0]["times"]) == 4
        px, py = project(data, [0.5, 0.3, 0.1])
        cx, cy = coverage_centroid(read_full(exr)[0]["A"])
        assert abs(px - cx) < 0.1 and abs(py - cy) < 0.1, (name, px, py, cx, cy)


def test_export_describes_models_weights_and_frames(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><frames rate="24"/><shutter open="0" close="0.5" weight="linear" center="0.25"/>'
                     '<object name="ball"><pointModel generate="sphere" count="500" radius="0.5" checker="2"/>'
                     '</object><object name="orb"><sphere radius="0.3"/></object></scene>')
    js = tmp_path / "s.json"
    assert run(["export", scene, "--frames", "2-3", "-o", js]).returncode == 0
    data = json.loads(js.read_text())
    assert [f["frame"] for f in data["frames"]] == [2, 3]
    assert data["frames"][0]["open"] == 2 / 24 and data["frames"][1]["close"] == 3 / 24 + 0.5
    gen = data["objects"][0]["model"]["generator"]
    assert gen["shape"] == "sphere" and gen["count"] == 500 and gen["checker"] == 2
    assert data["objects"][1]["model"]["sphere"]["radius"] == 0.3
    w = data["frames"][0]["weight"]
    assert w["kind"] == "linear" and len(w["samples"]) == 257
    t, a = w["samples"][128]  # the middle of the shutter is the weight's center: a = 1
    assert abs(t - (2 / 24 + 0.25)) < 1e-12 and abs(a - 1.0) < 1e-12
    bad = run(["export", scene, "-o", scene])
    assert bad.returncode == 1 and "input" in bad.stderr
    assert run(["export", "--help"]).returncode == 0


def test_export_refuses_non_finite_transforms_and_takes_the_renders_shutter(tmp_path):
    """Issue 23, item 14: JSON has no number for inf (a velocity of 1e308
    wrote 'inf' into the file); and --shutter, which a render may be given,
    is accepted by export with the same meaning: the frame's open and close
    are the render's."""
    scene = tmp_path / "s.xml"
    scene.write_text("""<scene><camera position="0 0 5" lookat="0 0 0" width="8" height="8"/>
<shutter open="0" close="10"/><object name="rocket"><sphere radius="0.5"/><animation><linear velocity="1e308 0 0"/></animation></object></scene>""")
    out = tmp_path / "s.json"
    proc = run(["export", scene, "--times", 1, "-o", out])
    assert proc.returncode == 1 and "object 'rocket'" in proc.stderr and "not finite" in proc.stderr, proc.stderr
    assert not out.exists()
    proc = run(["export", scene, "--shutter", "-1e-300,0", "--times", 1, "-o", out])
    assert proc.returncode == 0, proc.stderr
    frame = json.loads(out.read_text())["frames"][0]
    assert frame["open"] == -1e-300 and frame["close"] == 0
    proc = run(["export", scene, "--shutter", "2,1", "-o", out])
    assert proc.returncode == 2 and "--shutter: expected OPEN,CLOSE" in proc.stderr


def test_a_long_shutter_is_sampled_without_overflow_or_named(tmp_path):
    """Issue 23, item 14: the sample times were computed as (close - open)
    * (i + 0.5) before dividing by K, which overflowed for a shutter 1e308
    long, and the inf times were blamed on the still camera's transform.
    A shutter longer than a double holds is named as such."""
    scene = tmp_path / "s.xml"
    scene.write_text("""<scene><camera position="0 0 5" lookat="0 0 0" width="8" height="8"/>
<object name="ball"><sphere radius="0.5"/></object></scene>""")
    out = tmp_path / "s.json"
    proc = run(["export", scene, "--shutter", "0,1e308", "--times", 8, "-o", out])
    assert proc.returncode == 0, proc.stderr
    frame = json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"non-finite {c} in JSON"))["frames"][0]
    assert frame["times"][0] == 0 and frame["times"][-1] == 1e308
    assert frame["times"] == sorted(frame["times"]) and frame["weight"]["samples"][-1][0] == 1e308
    proc = run(["export", scene, "--shutter", "-1e308,1e308", "-o", out])
    assert proc.returncode == 1 and "shutter [-1e+308, 1e+308]: its length overflows" in proc.stderr, proc.stderr
    assert "camera" not in proc.stderr
