"""EXR header: numbers are stored as EXR numbers, the camera at the middle of
the frame's exposure as OpenEXR m44f worldToCamera / worldToNDC (row vectors,
Imath's convention), and a frame render names its frame and shutter. The
matrices are checked by projecting a small disc's center and finding it where
the render puts it (the centroid of its coverage), to a tenth of a pixel, for
every kind of camera motion (README, Output)."""
import json
import re
import shutil

import numpy as np
import pytest

from conftest import ROOT, coverage_centroid, read_full, run

DISC = """<scene><camera position="0.3 0.2 4" lookat="0 0 0" up="0.1 1 0" fov="40" width="{w}" height="{h}"/>
<frames rate="24"/>
<object position="{x} {y} {z}"><pointModel><splat center="0 0 0" normal="{nx} {ny} {nz}" radius="0.06"/>
</pointModel><material shading="unlit"/></object></scene>"""


def matrix(header, key):
    m = np.asarray(header[key], dtype=np.float64)
    assert m.shape == (16,), (key, header[key])
    return m.reshape(4, 4)


def test_numbers_are_numbers_and_frames_name_themselves(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(DISC.format(w=16, h=12, x=0, y=0, z=0, nx=0, ny=0, nz=1))
    out = tmp_path / "f.exr"
    assert run([scene, "-o", out, "--frame", 3, "--spp", 1, "--tspp", 2, "--quiet"]).returncode == 0
    _, h = read_full(out)
    assert h["refrender:spp"] == 1 and h["refrender:tspp"] == 2 and h["refrender:batches"] == 1
    assert isinstance(h["refrender:epsilon"], float) and h["refrender:frame"] == 3
    # the default shutter [0, 1] shifted by frame / rate
    assert h["refrender:shutterOpen"] == 3 / 24 and h["refrender:shutterClose"] == 1 + 3 / 24
    assert h["refrender:frameRate"] == 24.0


def test_world_to_ndc_projects_onto_the_rendered_position(tmp_path):
    width, height = 96, 64
    for k, (x, y, z) in enumerate([(0.8, 0.5, 0.3), (-1.1, -0.4, -0.5), (0.0, 0.9, 1.0)]):
        scene = tmp_path / f"d{k}.xml"
        to_eye = np.array([0.3, 0.2, 4.0]) - np.array([x, y, z])
        n = to_eye / np.linalg.norm(to_eye)  # face the camera: a round image
        scene.write_text(DISC.format(w=width, h=height, x=x, y=y, z=z, nx=n[0], ny=n[1], nz=n[2]))
        out = tmp_path / f"d{k}.exr"
        assert run([scene, "-o", out, "--sampler", "sobol", "--spp", 64, "--tspp", 1, "--quiet"]).returncode == 0
        ch, h = read_full(out)
        ndc = np.array([x, y, z, 1.0]) @ matrix(h, "worldToNDC")
        px, py = ndc[0] / ndc[3] * width, ndc[1] / ndc[3] * height
        cx, cy = coverage_centroid(ch["A"])
        assert abs(px - cx) < 0.1 and abs(py - cy) < 0.1, (px, py, cx, cy)
        cam = np.array([x, y, z, 1.0]) @ matrix(h, "worldToCamera")
        forward = -np.array([0.3, 0.2, 4.0]) / np.linalg.norm([0.3, 0.2, 4.0])
        assert np.isclose(cam[2], np.dot(np.array([x, y, z]) -
                          np.array([0.3, 0.2, 4.0]), forward), rtol=1e-5)  # z: depth along the view
        assert np.isclose(1.0 / (ndc[2] / ndc[3]), cam[2], rtol=1e-5)  # z: 1 / depth


def test_camera_matrices_beyond_float32_are_refused(tmp_path):
    """worldToCamera and worldToNDC are float32 in the header: a camera whose matrices hold a
    number past float's range (3.4e38) would be written as infinity. The intrinsics' own rules
    do not catch a tiny fov (its 1 / tan is 5.7e301) or a far position (the translation itself),
    so the header's check must: refused, naming the file and line, with no output written."""
    for camera in ('position="0 0.2 4" lookat="0 0 0" fov="1e-300"',
                   'position="0 0 4e38" lookat="0 0 0" fov="40"'):
        scene = tmp_path / "s.xml"
        scene.write_text(f'<scene>\n<camera {camera} width="8" height="8"/>\n'
                         '<object><sphere radius="1"/></object></scene>')
        out = tmp_path / "f.exr"
        proc = run([scene, "-o", out, "--spp", 1, "--tspp", 1, "--quiet"])
        assert proc.returncode != 0 and f"{scene}:2:" in proc.stderr and "float32" in proc.stderr, \
            (camera, proc.returncode, proc.stderr)
        assert not out.exists()
    # a scene whose camera fits at its own size, pushed past float by --res: named with both
    scene.write_text('<scene>\n<camera position="0 0 4" lookat="0 0 0" fov="1e-34" width="8" height="8"/>\n'
                     '<object><sphere radius="1"/></object></scene>')
    proc = run([scene, "-o", out, "--res", "1x1000", "--spp", 1, "--tspp", 1, "--quiet"])
    assert proc.returncode != 0 and f"{scene} with --res 1x1000:" in proc.stderr and "float32" in proc.stderr, \
        proc.stderr
    assert not out.exists()
    # the header's poses are the moving camera's (below): one whose worldToNDC (at the middle of the
    # exposure) moves past float's range within a frame of a sequence is refused, naming the frame and
    # the time, before any frame is written. 1 / (2 tan(fov / 2)) = 5.7e24 NDC units a world unit
    # across: frame 0's middle, 1e13 units from the rest pose, 5.7e37; frame 1's, 3e13 units, 1.7e38,
    # past FLT_MAX / 2
    scene.write_text('<scene>\n<camera position="0 0 4" lookat="0 0 0" fov="1e-23" width="8" height="8">'
                     '<animation><linear velocity="2e13 0 0"/></animation></camera><frames rate="1"/>\n'
                     '<object><sphere radius="1"/></object></scene>')
    proc = run([scene, "--frames", "0-1", "-o", tmp_path / "f%d.exr", "--spp", 1, "--tspp", 1, "--quiet"])
    assert proc.returncode == 1 and f"{scene}: frame 1: the camera's pose at time 1.5 holds" in proc.stderr \
        and "float32" in proc.stderr, proc.stderr
    assert not list(tmp_path.glob("f*.exr"))


# ---- the camera at a stated instant of the frame, for every camera kind ----

ANIM = """animVersion 1.1;
timeUnit sec;
linearUnit m;
angularUnit deg;
anim translate.translateX translateX cam 0 0 0;
animData {
  input time;
  output linear;
  weighted 0;
  keys {
    0 0 linear linear 1 1 0;
    1 0.5 linear linear 1 1 0;
  }
}
anim rotate.rotateY rotateY cam 0 0 1;
animData {
  input time;
  output angular;
  weighted 0;
  keys {
    0 0 linear linear 1 1 0;
    1 8 linear linear 1 1 0;
  }
}
"""

LOOK = 'position="0.3 0.2 4" lookat="0 0 0" up="0.1 1 0" fov="40" width="64" height="48"'
TURN = ('<animation><linear velocity="0.8 0.1 0"/><rotation axis="0 1 0" center="0.3 0.2 4" '
        'degrees_per_unit_time="10"/></animation>')
# name: (the <camera>, the <shutter> and <frames>, the frame's arguments, files copied from
# scenes/examples/, whether the camera is read by rows (then the discs lie on the middle row))
CAMERA_KINDS = {
    "look-at": (f'<camera {LOOK}/>', '<shutter open="0" close="1"/>', [], [], False),
    "keyframes": (f'<camera {LOOK}><animation><keyframes interpolation="spline"><key time="0" translate="0 0 0"/>'
                  '<key time="0.6" translate="0.3 0.1 0" rotate="0 5 2"/><key time="1" translate="0.7 0 0" '
                  'rotate="0 9 0"/></keyframes></animation></camera>', '<shutter open="0.1" close="0.8"/>', [], [],
                  False),
    "anim": (f'<camera {LOOK}><animation>cam.anim</animation></camera>', '<shutter open="0.2" close="0.9"/>', [],
             [], False),
    "trajectory": ('<camera fov="50" width="64" height="48"><trajectory file="poses.tum" axes="opengl" '
                   'interpolation="cubic"/></camera>', '<shutter open="1" close="2"/><frames at="trajectory"/>',
                   ["--frame", 2], ["poses.tum"], False),
    "cameras.json": ('<camera cameras="cameras.json" image="00012"><animation><pose time="0" image="00012"/>'
                     '<pose time="1" image="00013"/></animation></camera>', '<shutter open="0" close="1"/>', [],
                     ["cameras.json"], False),
    "transforms.json": ('<camera><trajectory file="transforms.json" interpolation="linear"/></camera>',
                        '<shutter open="0.2" close="0.9"/><frames rate="10"/>', ["--frame", 1],
                        ["transforms.json"], False),
    "rolling 3dgs-deblur": (f'<camera {LOOK}>{TURN}</camera>',
                            '<shutter open="0" close="0.2" rolling="3dgs-deblur" readoutTime="0.6"/>', [], [], True),
    "rolling gsplat": (f'<camera {LOOK}>{TURN}</camera>', '<shutter open="0" close="0.6" rolling="gsplat"/>', [], [],
                       True),
    "rolling lines": (f'<camera {LOOK}>{TURN}</camera>', '<shutter open="0" close="0.2" rolling="lines" '
                      'lineDelay="0.01"/>', [], [], True),
}
# The --time T whose sharp frame exposes the middle line at the frame's cameraTime (TRAJECTORIES.md, --time):
# 3dgs-deblur's middle line is at T; gsplat's lines span T to T + (close - open), as its frame's span open to
# close; a `lines` frame's middle line is at T + delta (L - 1) / 2, its window's centre in the frame at
# (open + close) / 2 + delta (L - 1) / 2.
SHARP_INSTANT = {"rolling gsplat": lambda h: h["refrender:shutterOpen"],
                 "rolling lines": lambda h: 0.5 * (h["refrender:shutterOpen"] + h["refrender:shutterClose"])}


def export_poses(tmp_path, scene, frame_args):
    """export --times 1: the camera's world-to-camera at the shutter's open, middle and close (export's
    own pose, written by its own code path), the camera-to-raster matrix and the resolution."""
    out = tmp_path / "e.json"
    proc = run(["export", scene, *frame_args, "--times", 1, "-o", out])
    assert proc.returncode == 0, proc.stderr
    e = json.loads(out.read_text())
    (frame,) = e["frames"]
    return [np.array(m) for m in frame["world_to_camera"]], np.array(e["camera"]["camera_to_raster"]), e["resolution"]


def place_discs(w2c, to_raster, rows):
    """Disc centres in world space at camera-space directions (a, b) and depths d of the pose w2c,
    each facing the camera, of about 1.5 pixels' radius: the image's middle row (b = 0) for a camera
    read by rows, whose middle line is the one exposed at the middle instant."""
    c2w = np.linalg.inv(w2c)
    eye = c2w[:3, 3]
    spots = [(-0.2, 0.0, 4.0), (0.05, 0.0, 3.0), (0.25, 0.0, 5.0)] if rows else \
        [(0.15, 0.1, 3.0), (-0.2, -0.05, 4.0), (0.02, -0.15, 5.0)]
    discs = []
    for a, b, d in spots:
        p = (c2w @ np.array([a * d, b * d, d, 1.0]))[:3]
        n = (eye - p) / np.linalg.norm(eye - p)
        discs.append((p, n, 1.5 * d / abs(to_raster[1][1])))
    return discs


def disc_xml(discs):
    return "".join(f'<object position="{p[0]!r} {p[1]!r} {p[2]!r}"><pointModel><splat center="0 0 0" '
                   f'normal="{n[0]!r} {n[1]!r} {n[2]!r}" radius="{r!r}"/></pointModel><material shading="unlit"/>'
                   '</object>' for p, n, r in discs)


def disc_centroids(alpha):
    """The coverage centroid (raster x, y) of each separate disc in the image."""
    from scipy import ndimage
    labels, n = ndimage.label(alpha > 0)
    return [coverage_centroid(np.where(labels == k, alpha, 0)) for k in range(1, n + 1)]


def f32(m):
    return np.asarray(m, dtype=np.float32).T.ravel()  # as Imath stores a column-vector matrix


@pytest.mark.parametrize("kind", CAMERA_KINDS)
def test_camera_attributes_are_the_camera_at_the_middle_of_the_exposure(tmp_path, kind):
    """For every kind of camera, worldToCamera and worldToNDC are the camera at refrender:cameraTime,
    the middle of the frame's exposure (of every line's, under a rolling shutter), and equal export's
    pose there; refrender:worldToCameraOpen and Close are export's poses at the shutter's ends.
    Independent check: discs placed at known points, rendered sharp (--time) at that instant by the
    ray tracer, are found where worldToNDC projects them, within 0.1 pixel. Under a rolling shutter
    only the middle line is seen at that instant: the discs lie on the middle row (3dgs-deblur: the
    sharp frame at T exposes the middle line at T; gsplat: its frame is sharp already, every line an
    instant between open and close, and --time at the open exposes them as the frame does; lines:
    SHARP_INSTANT). The rest
    pose, which the header held for every camera (a trajectory's at the world origin, 4 units from
    where it rendered), fails all but the still camera."""
    camera, shutter, frame_args, files, rows = CAMERA_KINDS[kind]
    for name in files:
        shutil.copy(ROOT / "scenes" / "examples" / name, tmp_path / name)
    (tmp_path / "cam.anim").write_text(ANIM)
    scene = tmp_path / "s.xml"
    write = lambda discs: scene.write_text(f'<scene>{camera}{shutter}<background color="0 0 0"/>{discs}</scene>')
    write('<object position="0 0 -100"><sphere radius="0.1"/></object>')
    poses, to_raster, (width, height) = export_poses(tmp_path, scene, frame_args)
    discs = place_discs(poses[1], to_raster, rows)
    write(disc_xml(discs))
    frame = tmp_path / "frame.exr"
    proc = run([scene, *frame_args, "--spp", 1, "--tspp", 1, "-o", frame, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    h = read_full(frame)[1]
    t = h["refrender:cameraTime"]
    # export's pose at cameraTime: its middle sample, except where a `lines` readout puts the middle line
    # past the shutter's middle (export's pose at the open of a shutter [t, t + 0.1])
    at = export_poses(tmp_path, scene, ["--shutter", f"{t!r},{t + 0.1!r}"])[0][0] if kind == "rolling lines" \
        else poses[1]
    assert np.array_equal(h["worldToCamera"], f32(at)), kind
    ndc = np.diag([1.0 / width, 1.0 / height, 1.0, 1.0]) @ to_raster @ at
    assert np.allclose(h["worldToNDC"], f32(ndc), rtol=1e-6, atol=1e-7), kind
    if not rows:  # a global shutter: its exposure is [open, close], export's ends
        assert np.array_equal(h["refrender:worldToCameraOpen"], f32(poses[0])), kind
        assert np.array_equal(h["refrender:worldToCameraClose"], f32(poses[-1])), kind
        assert (h["refrender:cameraTimeOpen"], h["refrender:cameraTimeClose"]) == \
            (h["refrender:shutterOpen"], h["refrender:shutterClose"])
    else:  # every line's: the first line's open to the last line's close
        line_times = [float(v) for v in re.findall(r"[-0-9.e]+(?=[],])", h["refrender:lineTimes"])]
        assert (h["refrender:cameraTimeOpen"], h["refrender:cameraTimeClose"]) == (line_times[0], line_times[-1])
    assert t == pytest.approx(0.5 * (h["refrender:cameraTimeOpen"] + h["refrender:cameraTimeClose"]), abs=1e-15)
    instant = SHARP_INSTANT.get(kind, lambda h: t)(h)
    sharp = tmp_path / "sharp.exr"
    proc = run([scene, "--time", repr(instant), "--sampler", "sobol", "--spp", 64, "-o", sharp, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    ch, hs = read_full(sharp)
    # the sharp frame at that instant records the same camera
    assert hs["refrender:cameraTime"] == pytest.approx(t, abs=1e-15), kind
    assert np.allclose(hs["worldToCamera"], h["worldToCamera"], rtol=0, atol=1e-6), kind
    found = disc_centroids(ch["A"])
    assert len(found) == len(discs), (kind, found)
    ndc_matrix = matrix(h, "worldToNDC")
    for p, _, _ in discs:
        q = np.array([*p, 1.0]) @ ndc_matrix
        px, py = q[0] / q[3] * width, q[1] / q[3] * height
        nearest = min(found, key=lambda c: np.hypot(c[0] - px, c[1] - py))
        assert np.hypot(nearest[0] - px, nearest[1] - py) < 0.1, (kind, (px, py), nearest)
