"""refrender export: a script with no refrender code projects a
disc's model-space center with the exported matrices, object to world to
camera to raster, and finds it where refrender renders it (the centroid of
its coverage) within 0.1 pixel: for a still scene, a keyframed object and a
moving camera. The shutter is 1e-7 long, so the exported time is the
rendered one."""
import hashlib
import json
import re

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
    """JSON has no number for inf (a velocity of 1e308
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
    """Regression: the sample times were computed as (close - open)
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


# A camera on a two-pose linear trajectory over [0, 1]; the image is W x H, so that a rolling shutter's
# lines are H rows (top-to-bottom) or W columns (left-to-right).
W, H = 8, 6
TUM = "0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n"
PREVIOUS = b"a file the export must leave as it was\n"


def trajectory_scene(tmp_path, shutter='<shutter open="0.4" close="0.6"/>', trajectory="p.tum"):
    if trajectory == "p.tum":
        (tmp_path / "p.tum").write_text(TUM)
    tum = trajectory.endswith(".tum")  # a transforms.json gives the camera's intrinsics itself
    camera = f'<camera fov="40" width="{W}" height="{H}">' if tum else "<camera>"
    axes = ' axes="opengl" interpolation="linear"' if tum else ""
    scene = tmp_path / "s.xml"
    scene.write_text(f'<scene>{camera}<trajectory file="{trajectory}"{axes}/></camera>{shutter}'
                     '<object name="ball"><sphere radius="0.5"/></object></scene>')
    return scene


def digests(paths):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() if p.exists() else None for p in paths}


def test_export_refuses_to_overwrite_its_inputs(tmp_path):
    """--tum and --transforms, like -o, may not name a file the scene is read from: the scene itself, its
    TUM trajectory, or the transforms.json it reads its poses from, however the name is spelled (./, a
    directory and .., a symbolic link). Each is refused, naming the option and both spellings, and no
    input nor the existing -o file changes (SHA-256 before and after)."""
    scene = trajectory_scene(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "link.tum").symlink_to("p.tum")
    out = tmp_path / "e.json"
    out.write_bytes(PREVIOUS)
    cases = [("--tum", "p.tum"), ("--tum", "./p.tum"), ("--tum", "sub/../p.tum"), ("--tum", "link.tum"),
             ("--transforms", "s.xml"), ("--transforms", str(scene)), ("-o", "./s.xml")]
    watched = [scene, tmp_path / "p.tum", out]
    before = digests(watched)
    for option, path in cases:
        args = ["export", "s.xml", "-o", "e.json", option, path] if option != "-o" else ["export", "s.xml", "-o", path]
        proc = run(args, cwd=tmp_path)
        assert proc.returncode == 1, (option, path, proc.stderr)
        assert f"{option} {path} is an input of this scene" in proc.stderr, proc.stderr
        assert digests(watched) == before, (option, path)
    # a scene whose poses are a transforms.json: --transforms naming it is refused the same way
    assert run(["export", "s.xml", "-o", "e0.json", "--transforms", "t.json"], cwd=tmp_path).returncode == 0
    poses = trajectory_scene(tmp_path, trajectory="t.json")
    before = digests([poses, tmp_path / "t.json"])
    proc = run(["export", "s.xml", "-o", "e1.json", "--transforms", "./t.json"], cwd=tmp_path)
    assert proc.returncode == 1 and "--transforms ./t.json is an input of this scene" in proc.stderr, proc.stderr
    assert digests([poses, tmp_path / "t.json"]) == before and not (tmp_path / "e1.json").exists()


def test_export_refuses_two_outputs_in_one_file(tmp_path):
    """Two outputs naming one file would leave only the later: refused before anything is written, naming
    both options, for the same file spelled alike, spelled differently, or through a symbolic link; a file
    already there keeps its bytes."""
    trajectory_scene(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "a.json").write_bytes(PREVIOUS)
    (tmp_path / "alias.json").symlink_to("a.json")
    cases = [["-o", "same.json", "--tum", "same.json"],
             ["-o", "e.json", "--tum", "x.txt", "--transforms", "./x.txt"],
             ["-o", "a.json", "--transforms", "alias.json"],
             ["-o", "sub/../a.json", "--tum", "a.json"],
             ["-o", "e.json", "--tum", "sub/t", "--transforms", str(tmp_path / "sub" / "t")]]
    for args in cases:
        proc = run(["export", "s.xml", *args], cwd=tmp_path)
        first, second = [args[i:i + 2] for i in range(0, len(args), 2)][-2:]
        assert proc.returncode == 1, (args, proc.stderr)
        assert f"{' '.join(first)} and {' '.join(second)} name the same file" in proc.stderr, proc.stderr
        assert (tmp_path / "a.json").read_bytes() == PREVIOUS
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "alias.json", "p.tum", "s.xml", "sub"], args
    assert list((tmp_path / "sub").iterdir()) == []


def test_export_writes_all_its_outputs_or_none(tmp_path):
    """--tum into a directory that does not exist was found only after the -o JSON had been written: every
    output is checked before any is written. A failure names the file; the files there keep their bytes
    and none is created. (A write or rename failing midway: tests/test_faults.py.)"""
    trajectory_scene(tmp_path)
    (tmp_path / "e.json").write_bytes(PREVIOUS)
    for args, named in [(["-o", "e.json", "--tum", "nodir/y.tum"], "nodir/y.tum"),
                        (["-o", "e.json", "--tum", "y.tum", "--transforms", "nodir/t.json"], "nodir/t.json"),
                        (["-o", "e.json", "--tum", "y.tum", "--transforms", "sub"], "sub")]:
        (tmp_path / "sub").mkdir(exist_ok=True)
        proc = run(["export", "s.xml", *args], cwd=tmp_path)
        assert proc.returncode == 1 and f"{named}: " in proc.stderr, (args, proc.stderr)
        assert (tmp_path / "e.json").read_bytes() == PREVIOUS and not (tmp_path / "y.tum").exists(), args
        assert [p.name for p in tmp_path.iterdir() if ".tmp-" in p.name or ".probe-" in p.name] == []


def lines_span(kind, value, lines):
    """The times the lines of a shutter [0.4, 0.6] are exposed, from the rolling shutters' definitions
    (scenes/README.md): 'lines' exposes line i over [open, close] + i lineDelay; '3dgs-deblur' line i at
    t + readoutTime ((i + 0.5) / lines - 0.5), t in [open, close]."""
    if kind == "lines":
        return 0.4, 0.6 + value * (lines - 1)
    reach = value * (0.5 - 0.5 / lines)
    return 0.4 - reach, 0.6 + reach


@pytest.mark.parametrize("kind,value,readout,accepted", [
    ("lines", 0.06, "top-to-bottom", True),          # H = 6 rows: the last closes at 0.6 + 5 x 0.06 = 0.9
    ("lines", 0.06, "left-to-right", False),         # W = 8 columns: 0.6 + 7 x 0.06 = 1.02
    ("lines", 0.1, "bottom-to-top", False),          # 0.6 + 5 x 0.1 = 1.1
    ("3dgs-deblur", 0.93, "top-to-bottom", True),    # 0.5 -+ (0.1 + 0.93 (0.5 - 1/12)) = [0.0125, 0.9875]
    ("3dgs-deblur", 0.93, "right-to-left", False),   # 0.5 -+ (0.1 + 0.93 (0.5 - 1/16)) = [-0.0069, 1.0069]
    ("gsplat", 0, "left-to-right", True),            # every line within [open, close]
])
def test_export_takes_the_renders_rule_for_a_rolling_shutter(tmp_path, kind, value, readout, accepted):
    """A rolling shutter exposes its lines past [open, close]: export checked only [open, close] against
    the trajectory's poses and exported frames that render refuses. Both now take one rule: every line's
    times within the poses, [0, 1] here, with the same message, which names the span of the lines'
    times (from the shutters' definitions, written out above)."""
    attr = {"lines": f'lineDelay="{value}"', "3dgs-deblur": f'readoutTime="{value}"', "gsplat": ""}[kind]
    scene = trajectory_scene(tmp_path, f'<shutter open="0.4" close="0.6" rolling="{kind}" readout="{readout}" '
                                       f'{attr}/>')
    lo, hi = lines_span(kind, value, W if readout in ("left-to-right", "right-to-left") else H)
    assert accepted == (0 <= lo and hi <= 1)
    exported = run(["export", scene, "-o", tmp_path / "e.json"])
    rendered = run([scene, "-o", tmp_path / "r.exr", "--spp", 1, "--tspp", 1, "--quiet"])
    assert (exported.returncode == 0) == accepted == (rendered.returncode == 0), (exported.stderr, rendered.stderr)
    if accepted:
        return
    message = exported.stderr.removeprefix("refrender export: ")
    assert exported.returncode == 1 and message == rendered.stderr.removeprefix("refrender: "), (exported.stderr,
                                                                                                  rendered.stderr)
    span = re.search(r"exposes lines over \[([^,]+), ([^\]]+)\]", message)
    assert span and abs(float(span[1]) - lo) < 1e-12 and abs(float(span[2]) - hi) < 1e-12, message
    assert f'rolling="{kind}"' in message and "covers [0, 1]" in message and "s.xml" in message
    assert not (tmp_path / "e.json").exists()


def test_the_rolling_shutter_is_given_as_fields(tmp_path):
    """Each frame's rolling shutter as the scene's attributes, one field each
    (before: one string to parse, 'lines bottom-to-top lineDelay ...')."""
    scene = tmp_path / "s.xml"
    for shutter, expect in (('<shutter open="0" close="0.5" rolling="lines" readout="bottom-to-top" lineDelay="0.01"/>',
                             {"kind": "lines", "readout": "bottom-to-top", "line_delay": 0.01, "readout_time": 0}),
                            ('<shutter open="0" close="0.5"/>', {"kind": "off"})):
        scene.write_text(f'<scene>{CAMERA.format(anim=STILL)}{shutter}<object><sphere radius="0.5"/></object></scene>')
        proc = run(["export", scene, "-o", tmp_path / "e.json"])
        assert proc.returncode == 0, proc.stderr
        data = json.loads((tmp_path / "e.json").read_text())
        assert data["frames"][0]["rolling_shutter"] == expect
        assert "line_delay" in data["conventions"]["rolling_shutter"]


def test_axes_give_opencv_and_opengl_camera_spaces(tmp_path):
    """--axes opencv|opengl: with the camera at (0, 0, 5) looking at the
    origin, up +y, the origin is 5 ahead: z = +5 in OpenCV's camera space
    (x right, y down, z forward), z = -5 in OpenGL's (y up, view along -z);
    the world's +x is camera +x in both, +y is camera -y in OpenCV's, +y in
    OpenGL's. The raster of any point is the same whichever axes (the pair
    world_to_camera, camera_to_raster changes together); a point above the
    centre lies above the raster's middle row (raster y down)."""
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera position="0 0 5" lookat="0 0 0" up="0 1 0" fov="40" width="96" height="64"/>'
                     '<object><sphere radius="0.5"/></object></scene>')
    got, raster = {}, {}
    for axes in ("refrender", "opencv", "opengl"):
        proc = run(["export", scene, "--axes", axes, "-o", tmp_path / f"{axes}.json"])
        assert proc.returncode == 0, proc.stderr
        data = json.loads((tmp_path / f"{axes}.json").read_text())
        w2c = np.asarray(data["frames"][0]["world_to_camera"][0])
        c2r = np.asarray(data["camera"]["camera_to_raster"])
        got[axes] = [w2c @ np.array([*p, 1.0]) for p in ((0, 0, 0), (1, 0, 0), (0, 1, 0))]
        x, y, _, w = c2r @ w2c @ np.array([0.3, 0.4, 0.2, 1.0])
        raster[axes] = (x / w, y / w)
        assert axes in data["conventions"]["camera_space"].lower() or axes == "refrender"
    origin, right, up = got["opencv"]
    assert np.allclose(origin[:3], [0, 0, 5]) and right[0] > 0 and up[1] < 0
    origin, right, up = got["opengl"]
    assert np.allclose(origin[:3], [0, 0, -5]) and right[0] > 0 and up[1] > 0
    assert np.allclose(raster["opencv"], raster["refrender"]) and np.allclose(raster["opengl"], raster["refrender"])
    assert raster["opencv"][1] < 32 and raster["opencv"][0] > 48
    bad = run(["export", scene, "--axes", "directx", "-o", tmp_path / "x.json"])
    assert bad.returncode == 2 and "--axes: refrender, opencv or opengl" in bad.stderr
