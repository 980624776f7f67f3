"""Cameras as trained models have them (cameras.json, written by 3DGS/2DGS
training: graphdeco-inria/gaussian-splatting utils/camera_utils.py). The
expectation is the pinhole projection the file defines, computed here from
its fields alone: camera coordinates R^T (P - position) (R's columns are the
camera's x right, y down, z forward axes), pixel = (fx x / z + W/2, fy y / z +
H/2) in refrender's raster (pixel (i, j) covers [i, i+1] x [j, j+1]). A
sub-pixel 2DGS Gaussian at P must render with its coverage centroid within
0.1 pixel of that point (a non-square image, fx != fy, a camera turned about
all three axes); a two-pose motion (position linear, rotation slerped,
checked against a textbook quaternion slerp) puts it where the pose of each
instant projects it."""
import json

import numpy as np
import pytest

import gsply
from conftest import coverage_centroid, read_exr, run

W, H = 96, 64
FX, FY = 80.0, 95.0


def rot(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def entry(name, R, C):
    return {"id": 0, "img_name": name, "width": W, "height": H, "position": list(map(float, C)),
            "rotation": [list(map(float, row)) for row in R], "fy": FY, "fx": FX}


def project(R, C, P):
    x, y, z = np.asarray(R).T @ (np.asarray(P) - np.asarray(C))
    return np.array([FX * x / z + W / 2, FY * y / z + H / 2])


def quat(R):
    w = np.sqrt(1 + np.trace(R)) / 2
    return np.array([w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)])


def rot_of(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def slerp(q0, q1, s):
    d = np.dot(q0, q1)
    if d < 0:
        q1, d = -q1, -d
    th = np.arccos(min(1.0, d))
    return (np.sin((1 - s) * th) * q0 + np.sin(s * th) * q1) / np.sin(th)


RA = rot([0.3, 1, 0.2], 0.5) @ rot([1, 0, 0], 0.2)
CA = np.array([0.4, -0.3, -3.0])
RB = rot([0.1, 0.4, 1], 0.25) @ RA
CB = np.array([0.9, -0.1, -2.8])
P = CA + RA @ np.array([0.25, -0.1, 3.2])  # in front of both cameras


def scene(tmp_path, camera_inner=""):
    (tmp_path / "cameras.json").write_text(json.dumps([entry("A.png", RA, CA), entry("B.png", RB, CB)]))
    ply = tmp_path / "g.ply"
    gsply.write(ply, {"mean": np.array([P]), "scale": np.array([[1e-4, 1e-4]]), "rot": np.array([[1.0, 0, 0, 0]]),
                      "opacity": np.array([0.9]), "sh": np.full((1, 1, 3), 1.0), "degree": 0})
    path = tmp_path / "s.xml"
    close = "/>" if not camera_inner else f">{camera_inner}</camera>"
    path.write_text(f'<scene><camera cameras="cameras.json" image="A.png"{close}'
                    f'<object name="g"><gaussianModel file="g.ply"/></object></scene>')
    return path


def centroid(tmp_path, path, *args):
    out = tmp_path / "o.exr"
    proc = run([path, "--spp", 64, "-o", out, "--quiet", *args])
    assert proc.returncode == 0, proc.stderr
    img = read_exr(out)[0]
    assert img.shape[:2] == (H, W)
    return np.array(coverage_centroid(img[..., 3]))


def test_a_cameras_json_camera_projects_as_the_file_defines(tmp_path):
    got = centroid(tmp_path, scene(tmp_path), "--time", 0)
    want = project(RA, CA, P)
    assert 10 < want[0] < W - 10 and 10 < want[1] < H - 10
    assert np.linalg.norm(got - want) < 0.1, (got, want)


def test_a_two_pose_motion_is_linear_in_position_and_slerped_in_rotation(tmp_path):
    path = scene(tmp_path, '<animation><pose time="0.2" image="A.png"/><pose time="1.2" image="B.png"/></animation>')
    for s in (0.0, 0.5, 1.0):
        R = rot_of(slerp(quat(RA), quat(RB), s))
        C = CA + s * (CB - CA)
        got = centroid(tmp_path, path, "--time", 0.2 + s)
        assert np.linalg.norm(got - project(R, C, P)) < 0.1, (s, got, project(R, C, P))
    # the midpoint of a slerp is not the pose halfway between by Euler angles or by matrices:
    assert np.linalg.norm(project(rot_of(slerp(quat(RA), quat(RB), 0.5)), (CA + CB) / 2, P) -
                          project(RA, (CA + CB) / 2, P)) > 1


@pytest.mark.parametrize("inner, attrs, why", [
    ("", ' image="C.png"', "no camera named 'C.png' (img_name); it has 'A.png', 'B.png' (2 cameras)"),
    ("", ' image="A.png" fov="30"', "drop 'fov'"),
    ("", "", "needs 'image'"),
    ('<animation><pose time="0" image="A.png"/></animation>', ' image="A.png"', "exactly two <pose>"),
    ('<animation><pose time="0" image="A.png"/><pose time="1e-310" image="B.png"/></animation>', ' image="A.png"',
     "too close for their motion"),
    ("", ' image="A.png" trainingResolution="3x"', "trainingResolution must be auto"),
])
def test_camera_mistakes_are_named(tmp_path, inner, attrs, why):
    scene(tmp_path)
    path = tmp_path / "bad.xml"
    close = "/>" if not inner else f">{inner}</camera>"
    path.write_text(f'<scene>\n<camera cameras="cameras.json"{attrs}{close}'
                    f'<object name="g"><gaussianModel file="g.ply"/></object></scene>')
    proc = run([path, "-o", tmp_path / "x.exr", "--quiet"])
    assert proc.returncode == 1 and why in proc.stderr and ("bad.xml:2" in proc.stderr or "cameras.json" in proc.stderr), proc.stderr


def loadcam_size(w, h, r):
    """gaussian-splatting utils/camera_utils.py loadCam, as Python computes it (round ties to even;
    int() truncates), for -r r (resolution_scale 1)."""
    if r in (1, 2, 4, 8):
        return round(w / r), round(h / r)
    down = (w / 1600 if w > 1600 else 1) if r == -1 else w / r
    return int(w / float(down)), int(h / float(down))


@pytest.mark.parametrize("size, attr, r", [((4946, 3286), "", -1), ((4946, 3286), ' trainingResolution="auto"', -1),
                                           ((4946, 3286), ' trainingResolution="2" pose', 2),
                                           ((1500, 1001), "", -1), ((4946, 3286), ' trainingResolution="4"', 4),
                                           ((1002, 666), ' trainingResolution="8"', 8),
                                           ((4946, 3286), ' trainingResolution="1237"', 1237)])
def test_a_camera_renders_at_the_size_its_model_was_trained_at(tmp_path, size, attr, r):
    """3DGS/2DGS train at loadCam's size (cameras.json holds COLMAP's full size): -r 1/2/4/8 divide it,
    -1 (the default) caps the width at 1600, another -r is a width; the field of view is kept. The
    expectation is loadCam's arithmetic written here in Python."""
    w, h = size
    (tmp_path / "cameras.json").write_text(json.dumps([dict(entry("A.png", np.eye(3), [0, 0, -3.0]), width=w,
                                                            height=h, fx=0.9 * w, fy=0.9 * w)]))
    path = tmp_path / "s.xml"
    close = "/>" if not attr.endswith(" pose") else \
        '><animation><pose time="0" image="A.png"/><pose time="1" image="A.png"/></animation></camera>'
    path.write_text(f'<scene><camera cameras="cameras.json" image="A.png"{attr.removesuffix(" pose")}{close}'
                    f'<object name="s"><sphere radius="1"/></object></scene>')
    proc = run(["export", path, "-o", tmp_path / "e.json"])
    assert proc.returncode == 0, proc.stderr
    exported = json.loads((tmp_path / "e.json").read_text())
    assert tuple(exported["resolution"]) == loadcam_size(w, h, r)
    fov = 2 * np.degrees(np.arctan(h / (2 * 0.9 * w)))
    assert abs(exported["camera"]["fov_y_degrees"] - fov) < 1e-9
