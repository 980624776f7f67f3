"""Camera trajectories from TUM files, checked end to end.

- A camera turning about its own centre sees a depth-independent homography:
  the ray through pixel x at time t is R(t) K^-1 x, so its blurred pixel is the
  time average of the sharp image at time 0 warped by H(t) = K R0^T R(t) K^-1.
  With opaque unlit spheres at two depths the sharp image is exact (a ray meets
  a sphere or not), so that average is computed here densely (4000 midpoint
  times) with the rotation from scipy's Slerp: independent of the renderer.
  The render must agree row by row (sum and first moment) within K = 4
  standard errors, for linear and se3 (a pure turn about the centre is the
  same screw) and for both axis conventions.
- Today's two-pose cameras.json motion is "linear" for two knots.
- Mistakes in the scene are named."""
import json
import shutil

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from conftest import ROOT, read_full, run

W, H, FOV = 40, 30, 50.0
F = H / 2 / np.tan(np.radians(FOV) / 2)
SPHERES = [(np.array([0.3, 0.2, 3.0]), 0.5), (np.array([-1.5, -0.4, 8.0]), 1.6)]  # OpenCV world: z forward
OPEN, CLOSE = 0.25, 0.75
K = 4.0
GL = np.diag([1.0, -1.0, -1.0])  # OpenCV camera axes -> OpenGL's (x right, y up, z back)


def tum_lines(times, rotations, positions, opengl):
    lines = []
    for t, R, p in zip(times, rotations, positions):
        q = Rotation.from_matrix(R @ GL if opengl else R).as_quat()  # x y z w
        lines.append(" ".join(f"{v:.17g}" for v in (t, *p, *q)))
    return "\n".join(lines) + "\n"


def knots():
    times = [0.0, 0.5, 1.0]
    rots = [Rotation.from_rotvec([0.0, 0.0, 0.0]), Rotation.from_rotvec([0.05, 0.25, 0.1]),
            Rotation.from_rotvec([0.12, 0.4, -0.05])]
    return times, rots


def scene(tmp_path, interpolation, opengl, tum=None):
    times, rots = knots()
    (tmp_path / "p.tum").write_text(tum if tum is not None else
                                    tum_lines(times, [r.as_matrix() for r in rots], [np.zeros(3)] * 3, opengl))
    spheres = "".join(f'<object position="{c[0]} {c[1]} {c[2]}"><sphere radius="{r}" color="1 1 1"/>'
                      f'<material shading="unlit"/></object>' for c, r in SPHERES)
    path = tmp_path / "s.xml"
    path.write_text(f'<scene><camera fov="{FOV}" width="{W}" height="{H}"><trajectory file="p.tum" '
                    f'axes="{"opengl" if opengl else "opencv"}" interpolation="{interpolation}"/></camera>'
                    f'<shutter open="{OPEN}" close="{CLOSE}"/><background color="0 0 0"/>{spheres}</scene>')
    return path


def dense_average(n=4000):
    times, rots = knots()
    slerp = Slerp(times, Rotation.concatenate(rots))
    i, j = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    d_cam = np.stack([(i - W / 2) / F, (j - H / 2) / F, np.ones_like(i)], axis=-1)
    d_cam /= np.linalg.norm(d_cam, axis=-1, keepdims=True)
    acc = np.zeros((H, W))
    for t in OPEN + (CLOSE - OPEN) * (np.arange(n) + 0.5) / n:
        d = d_cam @ slerp([t]).as_matrix()[0].T  # the camera at the origin, turned: the warped sharp image
        hit = np.zeros((H, W), bool)
        for c, r in SPHERES:
            along = d @ c
            hit |= (along > 0) & (c @ c - along ** 2 <= r * r)
        acc += hit
    return acc / n


EXPECTED = None


def rows_agree(ch, expect):
    got, se = ch["R"].astype(np.float64), ch["stderr.R"].astype(np.float64)
    ok = True
    for weight in (np.ones(W), np.arange(W) + 0.5 - W / 2):
        err = np.abs((got - expect) @ weight)
        ok = ok and bool(np.all(err <= K * np.sqrt((se ** 2) @ weight ** 2) + 2e-3 * np.abs(weight).sum() / W))
    return ok


@pytest.mark.parametrize("interpolation, opengl", [("linear", True), ("se3", False)])
def test_a_camera_turning_about_its_centre_blurs_as_the_warped_sharp_image(tmp_path, interpolation, opengl):
    global EXPECTED
    if EXPECTED is None:
        EXPECTED = dense_average()
    out = tmp_path / "o.exr"
    proc = run([scene(tmp_path, interpolation, opengl), "--pixel-filter", "point", "--spp", 1, "--tspp", 64,
                "--batches", 32, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    ch, _ = read_full(out)
    assert 0.05 < EXPECTED.mean() < 0.6 and (EXPECTED * (1 - EXPECTED)).sum() > 20  # blurred edges in the frame
    assert rows_agree(ch, EXPECTED)
    # planted: the other axis convention turns the camera the other way
    flipped = tmp_path / "f"
    flipped.mkdir()
    proc = run([scene(flipped, interpolation, not opengl, tum=(tmp_path / "p.tum").read_text()), "--pixel-filter",
                "point", "--spp", 1, "--tspp", 64, "--batches", 8, "-o", flipped / "o.exr", "--quiet"])
    assert proc.returncode == 0, proc.stderr
    assert not rows_agree(read_full(flipped / "o.exr")[0], EXPECTED)


def export_tum(tmp_path, scene_path, name, *args):
    out = tmp_path / f"{name}.tum"
    proc = run(["export", scene_path, "--times", 48, "--tum", out, "-o", tmp_path / f"{name}.json", *args])
    assert proc.returncode == 0, proc.stderr
    rows = np.array([[float(v) for v in line.split()] for line in out.read_text().splitlines()
                     if not line.startswith("#")])
    return rows


def poses(rows):
    """(times, positions, rotation matrices) of TUM rows; rotations compared as matrices (q ~ -q)."""
    return rows[:, 0], rows[:, 1:4], Rotation.from_quat(rows[:, 4:8]).as_matrix()


def test_a_two_pose_cameras_json_motion_is_the_linear_trajectory_of_its_poses(tmp_path):
    rA = Rotation.from_rotvec([0.1, 0.5, 0.05]).as_matrix()
    rB = Rotation.from_rotvec([0.2, 0.9, -0.1]).as_matrix()
    cA, cB = np.array([0.4, -0.3, -3.0]), np.array([0.9, -0.1, -2.6])
    entry = lambda n, R, C: {"id": 0, "img_name": n, "width": W, "height": H, "position": list(C),
                             "rotation": R.tolist(), "fx": F, "fy": F}
    (tmp_path / "cameras.json").write_text(json.dumps([entry("A", rA, cA), entry("B", rB, cB)]))
    two = tmp_path / "two.xml"
    two.write_text('<scene><camera cameras="cameras.json" image="A"><animation><pose time="0.2" image="A"/>'
                   '<pose time="0.9" image="B"/></animation></camera><shutter open="0.2" close="0.9"/>'
                   '<object><sphere radius="1"/></object></scene>')
    (tmp_path / "p.tum").write_text(tum_lines([0.2, 0.9], [rA, rB], [cA, cB], opengl=False))
    traj = tmp_path / "traj.xml"
    traj.write_text(f'<scene><camera fov="{FOV}" width="{W}" height="{H}"><trajectory file="p.tum" axes="opencv"/>'
                    '</camera><shutter open="0.2" close="0.9"/><object><sphere radius="1"/></object></scene>')
    ta, pa, ra = poses(export_tum(tmp_path, two, "two", "--tum-axes", "opencv"))
    tb, pb, rb = poses(export_tum(tmp_path, traj, "traj", "--tum-axes", "opencv"))
    assert np.array_equal(ta, tb) and len(ta) == 50
    assert np.abs(pa - pb).max() < 1e-9 and np.abs(ra - rb).max() < 1e-9
    # and both are lerp + scipy's slerp of the poses
    s = Slerp([0.2, 0.9], Rotation.from_matrix([rA, rB]))
    u = (ta - 0.2) / 0.7
    assert np.abs(pb - (cA + u[:, None] * (cB - cA))).max() < 1e-9
    assert np.abs(rb - s(ta).as_matrix()).max() < 1e-9


def test_export_writes_a_trajectory_back_as_it_read_it(tmp_path):
    """Exported at the knot times (a frame per segment), a linear path gives its knots back bit for bit."""
    times, rots = knots()
    text = tum_lines(times, [r.as_matrix() for r in rots], [np.array([0.1, 0.2, 0.3]) * k for k in range(3)],
                     opengl=True)
    path = scene(tmp_path, "linear", True, tum=text)
    for frame, (t0, t1) in enumerate(((0.0, 0.5), (0.5, 1.0))):
        rows = export_tum(tmp_path, path, f"f{frame}", "--times", 0, "--shutter", f"{t0},{t1}")
        want = [line.split() for line in text.splitlines()[frame:frame + 2]]
        got = [[f"{v:.17g}" for v in row] for row in rows]
        for g, w in zip(got, want):
            assert g[:4] == w[:4]
            q_got, q_want = np.array(g[4:], float), np.array(w[4:], float)
            assert np.array_equal(q_got, q_want) or np.array_equal(q_got, -q_want)


@pytest.mark.parametrize("traj, shutter, why", [
    ('file="p.tum" interpolation="linear"', "", "needs axes"),
    ('file="p.tum" axes="opengl" interpolation="spline"', "", "unknown interpolation 'spline'"),
    ('file="p.tum" axes="opengl" interpolation="cubic"', "", "3 poses; cubic interpolation needs at least 4"),
    ('file="p.tum" axes="opengl"', '<shutter open="0.5" close="1.5"/>',
     "the shutter [0.5, 1.5] reaches beyond the camera trajectory"),
    ('file="missing.tum" axes="opengl"', "", "missing.tum"),
])
def test_trajectory_mistakes_are_named(tmp_path, traj, shutter, why):
    times, rots = knots()
    (tmp_path / "p.tum").write_text(tum_lines(times, [r.as_matrix() for r in rots], [np.zeros(3)] * 3, True))
    s = tmp_path / "s.xml"
    s.write_text(f'<scene><camera fov="40" width="8" height="8"><trajectory {traj}/></camera>{shutter}'
                 '<object><sphere radius="1"/></object></scene>')
    proc = run([s, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode != 0 and why in proc.stderr, proc.stderr


def test_a_bad_tum_line_is_named_with_the_scene_line(tmp_path):
    (tmp_path / "p.tum").write_text("0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0\n")
    s = tmp_path / "s.xml"
    s.write_text('<scene>\n<camera fov="40" width="8" height="8">\n<trajectory file="p.tum" axes="opengl"/>'
                 '</camera><object><sphere radius="1"/></object></scene>')
    proc = run([s, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode != 0 and "p.tum:2: field 'qw' is missing" in proc.stderr and "s.xml:3" in proc.stderr


@pytest.mark.parametrize("spacings, why", [
    ([1] * 7, None),
    ([1, 1, 1, 0.1, 1, 1, 1], "p.tum:6: a cubic B-spline needs evenly spaced times"),
])
def test_cubic_times_at_unix_epoch_are_even_to_their_spacing(tmp_path, spacings, why):
    """TUM RGB-D's times are Unix seconds (~1.7e9) written to the microsecond: a 30 Hz file is even to
    1e-6 s (3e-5 of its spacing) and is rendered; one segment 10x short (0.03 s off) is refused, naming
    the file and line, as it is with times from 0 (a slack of |t|'s order once let it through)."""
    times = 1.7e9 + np.concatenate([[0.0], np.cumsum(spacings)]) / 30
    lines = [f"{t:.6f} {0.05 * k:.17g} 0 0 0 0 0 1" for k, t in enumerate(times)]
    (tmp_path / "p.tum").write_text("# t tx ty tz qx qy qz qw\n" + "\n".join(lines) + "\n")
    t0, t1 = times[2], times[3]
    s = tmp_path / "s.xml"
    s.write_text(f'<scene><camera fov="40" width="8" height="8"><trajectory file="p.tum" axes="opencv" '
                 f'interpolation="cubic"/></camera><shutter open="{t0!r}" close="{t1!r}"/>'
                 '<object position="0 0 4"><sphere radius="1"/></object></scene>')
    proc = run([s, "--spp", 1, "--tspp", 1, "-o", tmp_path / "o.exr", "--quiet"])
    if why is None:
        assert proc.returncode == 0, proc.stderr
    else:
        assert proc.returncode != 0 and why in proc.stderr and "(line 5)" in proc.stderr, proc.stderr


# ---- nerfstudio transforms.json: its camera, principal point off the centre ----

TW, TH, FX, FY, CX, CY = 64, 48, 70.0, 74.0, 40.5, 19.0  # the principal point 8.5 px right, 5 px up of centre


def transforms_scene(tmp_path, obj, extra="", poses=None):
    c2w_gl = np.eye(4)
    c2w_gl[:3, :3] = Rotation.from_rotvec([0.05, -0.1, 0.02]).as_matrix()
    c2w_gl[:3, 3] = [0.1, -0.05, 0.2]
    poses = poses if poses is not None else [c2w_gl, c2w_gl]
    doc = {"camera_model": "OPENCV", "fl_x": FX, "fl_y": FY, "cx": CX, "cy": CY, "w": TW, "h": TH, "k1": 0,
           "k2": 0, "p1": 0, "p2": 0, "frames": [{"file_path": f"{i}.png", "transform_matrix": m.tolist()}
                                                 for i, m in enumerate(poses)]}
    (tmp_path / "transforms.json").write_text(json.dumps(doc))
    s = tmp_path / "s.xml"
    s.write_text(f'<scene><camera><trajectory file="transforms.json"/></camera>{extra}'
                 f'<background color="0 0 0"/>{obj}</scene>')
    return s, c2w_gl


def projected(c2w_gl, P):
    """The pinhole projection the file defines: OpenGL camera axes, then (fx x/z + cx, fy y/z + cy) in OpenCV's."""
    x, y, z = (np.linalg.inv(c2w_gl) @ np.append(P, 1))[:3] * np.array([1, -1, -1])
    return np.array([FX * x / z + CX, FY * y / z + CY])


P_WORLD = np.array([0.4, 0.3, -3.5])


def test_a_transforms_json_camera_projects_with_its_principal_point_everywhere(tmp_path):
    """A small sphere, a sub-pixel 3DGS Gaussian (the rasterizer's own projection) and export's
    camera_to_raster each put P where the file's pinhole puts it, within 0.1 pixel."""
    sphere = f'<object position="{P_WORLD[0]} {P_WORLD[1]} {P_WORLD[2]}"><sphere radius="0.05"/></object>'
    s, c2w = transforms_scene(tmp_path, sphere)
    want = projected(c2w, P_WORLD)
    assert abs(CX - TW / 2) > 8 and 5 < want[0] < TW - 5 and 5 < want[1] < TH - 5
    out = tmp_path / "o.exr"
    proc = run([s, "--spp", 256, "--time", 0.5, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    ch, _ = read_full(out)
    assert ch["A"].shape == (TH, TW)
    from conftest import coverage_centroid
    assert np.linalg.norm(np.array(coverage_centroid(ch["A"])) - want) < 0.1
    import gsply
    ply = tmp_path / "g.ply"
    gsply.write(ply, {"mean": np.array([P_WORLD]), "scale": np.full((1, 3), 1e-4), "rot": np.array([[1.0, 0, 0, 0]]),
                      "opacity": np.array([0.9]), "sh": np.full((1, 1, 3), 1.0), "degree": 0})
    g = tmp_path / "g"
    g.mkdir()
    s2, _ = transforms_scene(g, f'<object><gaussianModel file="{ply}"/></object>')
    proc = run([s2, "--spp", 64, "--time", 0.5, "-o", g / "o.exr", "--quiet"])
    assert proc.returncode == 0, proc.stderr
    assert np.linalg.norm(np.array(coverage_centroid(read_full(g / "o.exr")[0]["A"])) - want) < 0.1
    proc = run(["export", s, "-o", tmp_path / "e.json", "--shutter", "0.5,0.6"])
    assert proc.returncode == 0, proc.stderr
    e = json.loads((tmp_path / "e.json").read_text())
    m = np.array(e["camera"]["camera_to_raster"]) @ np.array(e["frames"][0]["world_to_camera"][0])
    X = m @ np.append(P_WORLD, 1)
    assert np.linalg.norm(X[:2] / X[3] - want) < 1e-9


def test_a_transforms_json_round_trips_through_export(tmp_path):
    """export --transforms writes the camera and poses back; read again and written again, the file is the same
    byte for byte (read, write, read back bit-identically), and its TUM path too. The identity
    and a quarter turn (exact zeros: a writer's arithmetic must not flip their signs) among the poses."""
    quarter = np.eye(4)
    quarter[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]
    general = np.eye(4)
    general[:3, :3] = Rotation.from_rotvec([0.5, -0.9, 0.2]).as_matrix()
    general[:3, 3] = [0.1, -0.05, 0.2]
    s, _ = transforms_scene(tmp_path, '<object><sphere radius="1"/></object>', '<shutter open="0" close="2"/>',
                            poses=[np.eye(4), quarter, general])
    proc = run(["export", s, "-o", tmp_path / "e.json", "--tum", tmp_path / "a.tum", "--transforms",
                tmp_path / "back.json"])
    assert proc.returncode == 0, proc.stderr
    back = json.loads((tmp_path / "back.json").read_text())
    # the camera keeps fields of view (so that --res keeps the view): the first read moves a focal length by ulps
    assert np.allclose([back[k] for k in ("fl_x", "fl_y", "cx", "cy")], [FX, FY, CX, CY], rtol=1e-12, atol=0)
    assert (back["w"], back["h"]) == (TW, TH)
    # export writes poses at its times, between the knots too: read back, those are knots, and from
    # then on reading and writing are exact: the second and third exports are the same file, and the
    # poses read from the first and the second export are the same bits (their TUM exports agree)
    for k in (1, 2):
        src = "back.json" if k == 1 else f"back{k}.json"
        (tmp_path / f"s{k}.xml").write_text(f'<scene><camera><trajectory file="{src}"/></camera><object><sphere '
                                            'radius="1"/></object><shutter open="0" close="2"/></scene>')
        proc = run(["export", tmp_path / f"s{k}.xml", "-o", tmp_path / f"e{k}.json", "--tum", tmp_path / f"r{k}.tum",
                    "--transforms", tmp_path / f"back{k + 1}.json"])
        assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "back3.json").read_bytes() == (tmp_path / "back2.json").read_bytes()
    r1, r2 = ([x for x in (tmp_path / f"r{k}.tum").read_text().splitlines() if not x.startswith("#")] for k in (1, 2))
    assert r1 == r2 and len(r1) == 10 and not any(" -0 " in f" {x} " for x in r1)
    # and the identity and the quarter turn came through with their exact zeros, unsigned
    first = json.loads((tmp_path / "back2.json").read_text())["frames"][0]["transform_matrix"]
    assert first == [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    assert "-0," not in (tmp_path / "back2.json").read_text().replace(" ", "")


def test_transforms_json_camera_mistakes_are_named(tmp_path):
    s, _ = transforms_scene(tmp_path, '<object><sphere radius="1"/></object>')
    s.write_text(s.read_text().replace("<camera>", '<camera fov="40">'))
    proc = run([s, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode != 0 and "takes its intrinsics from the file: drop 'fov'" in proc.stderr
    s.write_text(s.read_text().replace('<camera fov="40">', "<camera>").replace(
        'file="transforms.json"', 'file="transforms.json" axes="opencv"'))
    proc = run([s, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode != 0 and "drop 'axes'" in proc.stderr


@pytest.mark.parametrize("where, key, value, named", [
    ("frame", "k1", 0.3, 'distortion frames[1].k1 = 0.3'),
    ("top", "k1", "0.3", 'distortion k1 = "0.3"'),
    ("frame", "camera_model", "OPENCV_FISHEYE", 'frames[1].camera_model = "OPENCV_FISHEYE"'),
    ("frame", "fl_x", "70", 'frames[1].fl_x = "70" is not a number'),
    ("top", "fl_x", 1e-14, "fl_x = 1e-14 gives no usable field of view"),
    ("top", "fl_x", 1e300, "fl_x = 1e+300 gives no usable field of view"),
    ("top", "cx", 1e300, "cx = 1e+300 is too far off the image"),
    ("frames", 1, 2, "frames[1] = 2: a frame is an object"),
])
def test_transforms_json_keys_it_cannot_honour_are_refused_by_entry(tmp_path, where, key, value, named):
    """A distortion or camera model in a frame or as a string rendered as a pinhole, exit 0; intrinsics out of
    cameras.json's range rendered all background or wrote infinity into worldToNDC; a frame that is a number was
    miscounted. Each is refused naming the file, the entry and its value, and no image is written."""
    s, _ = transforms_scene(tmp_path, '<object><sphere radius="1"/></object>')
    doc = json.loads((tmp_path / "transforms.json").read_text())
    doc["frames"].append(dict(doc["frames"][0]))
    if where == "frames":
        doc["frames"].insert(key, value)
    else:
        (doc["frames"][1] if where == "frame" else doc)[key] = value
    (tmp_path / "transforms.json").write_text(json.dumps(doc))
    out = tmp_path / "o.exr"
    proc = run([s, "-o", out, "--spp", 1, "--quiet"])
    assert proc.returncode != 0 and f"transforms.json: {named}" in proc.stderr, proc.stderr
    assert not out.exists()


# ---- every interpolation against an independent reference ----

def reference_knots():
    """Six evenly spaced knots turning about changing axes (up to ~50 degrees) and moving."""
    rng = np.random.default_rng(7)
    times = 0.5 + 0.25 * np.arange(6)
    rots = Rotation.from_rotvec(rng.normal(scale=0.35, size=(6, 3)))
    pos = rng.normal(scale=0.6, size=(6, 3))
    return [(t, p, q) for t, p, q in zip(times, pos, rots.as_quat())]  # q: x y z w


@pytest.mark.parametrize("interpolation", ["linear", "se3", "cubic", "bezier", "bezier-se3"])
def test_each_interpolation_equals_the_independent_reference(tmp_path, interpolation):
    """tests/trajectory_reference.py was written from the methods' sources (named there, with commit and
    line) by a helper who had not seen trajectory.c: the camera path refrender exports at 50 times over
    the interpolation's whole domain equals it within 1e-9 (position and rotation matrix)."""
    import trajectory_reference as ref
    knots = reference_knots()
    (tmp_path / "p.tum").write_text("\n".join(" ".join(f"{v:.17g}" for v in (t, *p, *q)) for t, p, q in knots) + "\n")
    t0, t1 = (knots[1][0], knots[-2][0]) if interpolation == "cubic" else (knots[0][0], knots[-1][0])
    s = tmp_path / "s.xml"
    s.write_text(f'<scene><camera fov="40" width="8" height="8"><trajectory file="p.tum" axes="opencv" '
                 f'interpolation="{interpolation}"/></camera><shutter open="{t0!r}" close="{t1!r}"/>'
                 '<object><sphere radius="1"/></object></scene>')
    times, pos, rot = poses(export_tum(tmp_path, s, "x", "--tum-axes", "opencv"))
    assert len(times) == 50
    fn = {"linear": ref.pose_linear, "se3": ref.pose_se3, "cubic": ref.pose_cubic, "bezier": ref.pose_bezier,
          "bezier-se3": ref.pose_bezier_se3}[interpolation]
    for t, p, R in zip(times, pos, rot):
        p_ref, R_ref = fn(knots, t)
        assert np.abs(p - p_ref).max() < 1e-9 and np.abs(R - R_ref).max() < 1e-9, (interpolation, t)


def frames_scene(tmp_path, frames='<frames at="trajectory"/>', camera=None):
    """Poses at uneven times (a dataset's frames): 0, 0.5, 1, 1.7."""
    (tmp_path / "p.tum").write_text("0 0 0 0 0 0 0 1\n0.5 0.1 0 0 0 0 0 1\n1 0.2 0 0 0 0 0 1\n1.7 0.3 0 0 0 0 0 1\n")
    cam = camera or '<camera width="16" height="16" fov="40"><trajectory file="p.tum" axes="opencv"/></camera>'
    s = tmp_path / "f.xml"
    s.write_text(f'<scene>{cam}{frames}<shutter open="0" close="0.1"/>'
                 '<object position="0 0 4"><sphere radius="1"/></object></scene>')
    return s


def test_frames_at_the_trajectory_centre_each_exposure_on_its_pose(tmp_path):
    """A blurred frame of a dataset spans its pose's time, the exposure's length the shutter's:
    frame k's window is centred on pose k (the middle of [open, close] is the pose's time, exactly as
    the shift of a binary64 sum allows)."""
    s = frames_scene(tmp_path)
    proc = run(["export", s, "-o", tmp_path / "e.json", "--frames", "1-2"])
    assert proc.returncode == 0, proc.stderr
    frames = json.loads((tmp_path / "e.json").read_text())["frames"]
    for f, pose_time in zip(frames, (0.5, 1.0)):
        assert abs(0.5 * (f["open"] + f["close"]) - pose_time) < 1e-15
        assert abs(f["close"] - f["open"] - 0.1) < 1e-15
    out = tmp_path / "o.exr"
    proc = run([s, "--frame", 2, "--spp", 1, "--tspp", 2, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    header = read_full(out)[1]
    assert header["refrender:frame"] == 2 and "refrender:frameRate" not in header
    assert [float(v) for v in header["refrender:shutter"].split()] == pytest.approx([0.95, 1.05], abs=1e-15)
    # without --frame the shutter as written (or as --time sets it), as with frames at a rate
    proc = run([s, "--time", 1.7, "--spp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 0 and read_full(out)[1]["refrender:shutter"].split() == ["1.7", "1.7"], proc.stderr
    # frame 0, centred on pose 0, reaches before it: a sequence is refused before any frame is written,
    # and export refuses it as render does
    proc = run([s, "--frames", "0-3", "--spp", 1, "--tspp", 2, "-o", tmp_path / "f%d.exr", "--quiet"])
    assert proc.returncode != 0 and "reaches beyond the camera trajectory" in proc.stderr
    assert not list(tmp_path.glob("f*.exr"))
    proc = run(["export", s, "-o", tmp_path / "e0.json", "--frames", "0-1"])
    assert proc.returncode != 0 and "reaches beyond the camera trajectory" in proc.stderr
    proc = run([s, "--frame", 4, "-o", out, "--quiet"])
    assert proc.returncode != 0 and "frame 4: the camera's trajectory has 4 poses (frames 0 to 3)" in proc.stderr


def test_a_refused_frame_is_named_and_a_moved_shutter_is_said(tmp_path):
    """A sequence with a frame whose exposure leaves the camera trajectory is refused before any
    frame is written, by render and export alike: the message names that frame and, with frames at
    the trajectory's poses, the pose its exposure was centred on (it said only 'the shutter [0.5,
    1.5] reaches beyond ...', which is no shutter the scene or the command line gave). Frames at a
    rate are named too (frame 16, [1.6, 1.7 + 2 ulps], past the last pose at 1.7). <frames at="trajectory"> renders the shutter as written moved onto each pose:
    a note says so, with the first frame's shutter (the run was silent); --quiet drops it, and frames
    at a rate, whose shift the shutter's docs state, have none."""
    for name in ("trajectory.xml", "poses.tum"):
        shutil.copy(ROOT / "scenes" / "examples" / name, tmp_path / name)
    example = tmp_path / "trajectory.xml"
    for frames, frame, window in (("1-6", 1, "[0.5, 1.5]"), ("2-5", 5, "[4.5, 5.5]")):
        proc = run([example, "--frames", frames, "--res", "12x8", "--spp", 1, "--tspp", 1, "-o",
                    tmp_path / "t.%04d.exr", "--quiet"])
        assert proc.returncode == 1 and f"{example}: frame {frame} (its exposure centred on pose {frame}'s time " \
            f"{frame}): the shutter {window} reaches beyond the camera trajectory" in proc.stderr, proc.stderr
        assert not list(tmp_path.glob("t.*.exr"))
        proc = run(["export", example, "--frames", frames, "-o", tmp_path / "e.json"])
        assert proc.returncode == 1 and f"frame {frame} (its exposure centred on pose {frame}'s time {frame}): " \
            f"the shutter {window} reaches beyond" in proc.stderr, proc.stderr
    at_rate = frames_scene(tmp_path, '<frames rate="10"/>')
    proc = run([at_rate, "--frames", "0-20", "--spp", 1, "--tspp", 1, "-o", tmp_path / "r%d.exr"])
    assert proc.returncode == 1 and "f.xml: frame 16: the shutter [1.6" in proc.stderr and "note" not in \
        proc.stderr, proc.stderr
    note = ('note: <frames at="trajectory">: each frame\'s exposure is the shutter [0, 0.1] moved so that its middle '
            "is its pose's time (frame {}: {})")
    s = frames_scene(tmp_path)
    proc = run([s, "--frame", 2, "--spp", 1, "--tspp", 1, "-o", tmp_path / "o.exr"])
    assert proc.returncode == 0 and f"refrender: {note.format(2, '[0.95, 1.05]')}\n" in proc.stderr, proc.stderr
    proc = run([s, "--frame", 2, "--spp", 1, "--tspp", 1, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    proc = run(["export", s, "--frames", "1-2", "-o", tmp_path / "e.json"])
    assert proc.returncode == 0 and proc.stderr == f"refrender export: {note.format(1, '[0.45, 0.55]')}\n", \
        proc.stderr
    proc = run([s, "--time", 1, "--spp", 1, "-o", tmp_path / "o.exr"])  # no frame: the shutter as given
    assert proc.returncode == 0 and "note" not in proc.stderr, proc.stderr


@pytest.mark.parametrize("frames,camera,message", [
    ('<frames at="poses"/>', None, '<frames at="poses">: the frames can be at="trajectory"'),
    ('<frames at="trajectory" rate="24"/>', None, "'rate' or at=\"trajectory\", not both"),
    ('<frames rate="24"/><frames at="trajectory"/>', None, "a second <frames>: a scene has one"),
    ('<frames at="trajectory"/>', '<camera width="16" height="16" fov="40"/>', 'f.xml:1: <frames at="trajectory"> '
     'needs a <camera> with a <trajectory>'),
])
def test_frames_at_the_trajectory_mistakes_are_named(tmp_path, frames, camera, message):
    proc = run([frames_scene(tmp_path, frames, camera), "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode != 0 and message in proc.stderr, proc.stderr


def test_export_tum_rate_writes_evenly_spaced_poses_that_a_cubic_accepts(tmp_path):
    """export --tum-rate R writes the camera's poses at the multiples of 1/R within the exported
    span. A camera moving along x at unit speed (position x = t, closed form) exported over
    [0.05, 0.97] at 10 per unit has its poses at k/10, k = 1..9 (Python's k / 10 is the nearest
    double, as C's), at x = t; a cubic B-spline reads that file, where the export's own times
    (0.05, K between, 0.97: its ends closer to their neighbours than the steps) are refused as
    uneven. --transforms takes the same times. Frames at a trajectory's poses span their
    exposures: frames 2-4 of scenes/examples/trajectory.xml (exposures of 1 centred on 2, 3, 4)
    at 4 per unit are the 13 times 1.5, 1.75, ..., 4.5."""
    scene = tmp_path / "lin.xml"
    scene.write_text('<scene><camera position="0 0 5" lookat="0 0 0" up="0 1 0" fov="40" width="16" height="12">'
                     '<animation><linear velocity="1 0 0"/></animation></camera><shutter open="0.05" close="0.97"/>'
                     '<object><sphere radius="1"/></object></scene>')
    proc = run(["export", scene, "--tum-rate", 10, "--tum", tmp_path / "even.tum", "--transforms",
                tmp_path / "even.json", "-o", tmp_path / "e.json"])
    assert proc.returncode == 0, proc.stderr
    rows = [list(map(float, line.split())) for line in (tmp_path / "even.tum").read_text().splitlines()
            if not line.startswith("#")]
    assert [r[0] for r in rows] == [k / 10 for k in range(1, 10)]
    assert np.allclose([r[1:] for r in rows], [[k / 10, 0, 5, 0, 0, 0, 1] for k in range(1, 10)], rtol=0, atol=1e-12)
    frames = json.loads((tmp_path / "even.json").read_text())["frames"]
    assert [f["time"] for f in frames] == [k / 10 for k in range(1, 10)]
    proc = run(["export", scene, "--times", 48, "--tum", tmp_path / "uneven.tum", "-o", tmp_path / "u.json"])
    assert proc.returncode == 0, proc.stderr

    def cubic(tum):
        xml = tmp_path / f"{tum}.xml"
        xml.write_text(f'<scene><camera fov="40" width="16" height="12"><trajectory file="{tum}" axes="opengl" '
                       'interpolation="cubic"/></camera><shutter open="0.3" close="0.7"/>'
                       '<object position="0 0 0"><sphere radius="1"/></object></scene>')
        return run([xml, "--spp", 1, "--tspp", 2, "--quiet", "-o", tmp_path / f"{tum}.exr"])
    assert cubic("even.tum").returncode == 0, cubic("even.tum").stderr
    refused = cubic("uneven.tum")
    assert refused.returncode == 1 and "evenly spaced" in refused.stderr, refused.stderr
    example = ROOT / "scenes" / "examples" / "trajectory.xml"
    proc = run(["export", example, "--frames", "2-4", "--tum-rate", 4, "--tum", tmp_path / "f.tum", "-o",
                tmp_path / "f.json"])
    assert proc.returncode == 0, proc.stderr
    times = [float(line.split()[0]) for line in (tmp_path / "f.tum").read_text().splitlines() if line[0] != "#"]
    assert times == [k / 4 for k in range(6, 19)]


def test_export_tum_rate_mistakes_are_named(tmp_path):
    scene = ROOT / "scenes" / "examples" / "trajectory.xml"
    for args, why in [(["--tum-rate", 4], "give one of them"), (["--tum-rate", 0, "--tum", tmp_path / "a.tum"], "> 0"),
                      (["--tum-rate", "nan", "--tum", tmp_path / "a.tum"], "nan")]:
        proc = run(["export", scene, *args, "-o", tmp_path / "x.json"])
        assert proc.returncode == 2 and "--tum-rate" in proc.stderr and why in proc.stderr, (args, proc.stderr)
    proc = run(["export", scene, "--shutter", "1.2,1.3", "--tum-rate", 2, "--tum", tmp_path / "a.tum", "-o",
                tmp_path / "x.json"])
    assert proc.returncode == 1 and "no multiple of 1/2 lies in the exported span" in proc.stderr, proc.stderr
    # k / R with k beyond 2^53 is no longer every multiple (and 1.7e308 made k inf, cast to an int: UBSan)
    for rate in ["1.7e308", "1e16"]:
        proc = run(["export", scene, "--tum-rate", rate, "--tum", tmp_path / "a.tum", "-o", tmp_path / "x.json"])
        assert proc.returncode == 1 and "beyond 2^53" in proc.stderr, (rate, proc.stderr)
    assert not list(tmp_path.iterdir())
