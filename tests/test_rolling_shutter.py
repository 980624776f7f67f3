"""Rolling shutter against the analytic answer.

A camera translating at speed v along x sees an opaque unlit sphere (colour 1)
over a black background. Through a pixel's centre (--pixel-filter point) the ray
from the camera at c(t) = (v t, 0, 0) with direction d meets the sphere (centre C,
radius R) while |w|^2 - (w.d)^2 <= R^2, w = C - c(t): a quadratic in t. So the
pixel's expected value is the length of the part of its line's exposure window
where that quadratic is <= 0, over the window's length: exact, independent of
the renderer. Each line's window:
- lines: [open, close] + delta r, r counted along the readout direction (the
  general model, refrender's own definition);
- 3dgs-deblur and gsplat / 3DGUT: from tests/rolling_shutter_reference.py,
  written by a helper who had not seen refrender's C nor this test, from
  3dgs-deblur's gsplat fork 64154bb (forward.cu:335-336, 360-363), gsplat
  90d7b4b (Cameras.cuh:486-528) and 3dgrut a37ef72 (cameraProjections.cuh:50-65);
  its module docstring has the lines and the conventions' differences.
A row with a fronto-parallel edge is thereby shifted by f v delta r / Z and
box-blurred by f v T_e / Z, which the quadratic holds as a special case.

Statistics: each row's sum over pixels and its first moment about the centre
column (a shift moves the moment, not the sum) are compared with the analytic
ones within K = 4 standard errors (64 comparisons, 32 batches; a false failure
about 4e-3 by the normal tail). A wrong line index or delay fails by far, and
3dgs-deblur's half line (0.07 pixels here) too (the planted checks below)."""
import re

import numpy as np
import pytest

import rolling_shutter_reference as reference
from conftest import read_full, run

W, H, FOV = 48, 32, 40.0
V = 2.0
CENTRE, RADIUS = np.array([0.0, 0.1, -4.0]), 1.0
OPEN, CLOSE = 0.0, 0.1
K = 4.0


def pixel_directions():
    """Unit world directions through the pixel centres of a camera at the origin looking down -z, y up."""
    th = np.tan(np.radians(FOV) / 2)
    i, j = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    x = (2 * i / W - 1) * th * W / H
    y = (1 - 2 * j / H) * th
    d = np.stack([x, y, -np.ones_like(x)], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def covered_time(t0, t1):
    """Per pixel: how long in [t0, t1] (arrays H x W) the pixel's ray meets the sphere."""
    d = pixel_directions()
    e = np.array([1.0, 0, 0])
    ed, cd, ce = d @ e, d @ CENTRE, CENTRE @ e
    a = V * V * (1 - ed ** 2)
    b = -2 * V * ce + 2 * V * ed * cd
    c = CENTRE @ CENTRE - cd ** 2 - RADIUS ** 2
    disc = b * b - 4 * a * c
    root = np.sqrt(np.maximum(disc, 0))
    lo, hi = (-b - root) / (2 * a), (-b + root) / (2 * a)
    inside = np.clip(np.minimum(hi, t1) - np.maximum(lo, t0), 0, None)
    return np.where(disc > 0, inside, 0.0)


def line_index(readout):
    j, i = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
    return {"top-to-bottom": (j, H), "bottom-to-top": (H - 1 - j, H), "left-to-right": (i, W),
            "right-to-left": (W - 1 - i, W)}[readout]


def expected(kind, readout="top-to-bottom", delay=0.0, t_ro=0.0):
    r, lines = line_index(readout)
    if kind == "lines":
        t0 = OPEN + delay * r
        return covered_time(t0, t0 + CLOSE - OPEN) / (CLOSE - OPEN)
    if kind == "3dgs-deblur":  # always top to bottom in its source
        rows = np.broadcast_to(np.arange(H)[:, None], (H, W))
        t0, t1 = reference.deblur3dgs_row_window(rows, H, OPEN, CLOSE, t_ro)
        return covered_time(t0, t1) / (CLOSE - OPEN)
    raise ValueError(kind)


def gsplat_instants(readout, convention=reference.gsplat_row_instant):
    j, i = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
    return convention(j, i, W, H, OPEN, CLOSE, readout.replace("-", "_"))


def _no_half_line(t_ro):
    r, lines = line_index("top-to-bottom")
    mid = 0.5 * (OPEN + CLOSE) + t_ro * (r / lines - 0.5)
    return covered_time(mid - (CLOSE - OPEN) / 2, mid + (CLOSE - OPEN) / 2) / (CLOSE - OPEN)


def scene(tmp_path, shutter_attrs, name="s"):
    xml = (f'<scene><camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="{FOV}" width="{W}" height="{H}">'
           f'<animation><linear velocity="{V} 0 0"/></animation></camera>'
           f'<shutter open="{OPEN}" close="{CLOSE}" {shutter_attrs}/><background color="0 0 0"/>'
           f'<object position="{CENTRE[0]} {CENTRE[1]} {CENTRE[2]}"><sphere radius="{RADIUS}" color="1 1 1"/>'
           f'<material shading="unlit"/></object></scene>')
    p = tmp_path / f"{name}.xml"
    p.write_text(xml)
    return p


def render(tmp_path, shutter_attrs, *args, name="s"):
    out = tmp_path / f"{name}.exr"
    proc = run([scene(tmp_path, shutter_attrs, name), "--pixel-filter", "point", "--spp", 1, "--tspp", 64,
                "--batches", 32, "--seed", 3, "-o", out, "--quiet", *args])
    assert proc.returncode == 0, proc.stderr
    return read_full(out)


def rows_agree(ch, expect):
    """Each row's sum and its first moment about the image's centre column (which a shift of the
    row moves: a sum alone does not see it) within K standard errors of the analytic ones."""
    got, se = ch["R"].astype(np.float64), ch["stderr.R"].astype(np.float64)
    ok = True
    errs = []
    for weight in (np.ones(W), np.arange(W) + 0.5 - W / 2):
        err = np.abs((got - expect) @ weight)
        bound = K * np.sqrt((se ** 2) @ weight ** 2) + 1e-5
        ok = ok and bool(np.all(err <= bound))
        errs.append(err / bound * K)
    return ok, errs[0], errs[1]


@pytest.mark.parametrize("readout", ["top-to-bottom", "bottom-to-top", "left-to-right", "right-to-left"])
def test_each_line_is_exposed_over_its_own_window(tmp_path, readout):
    delay = 0.01  # the readout spans 0.32 (or 0.48): lines several pixels apart
    ch, header = render(tmp_path, f'rolling="lines" readout="{readout}" lineDelay="{delay}"')
    expect = expected("lines", readout, delay)
    ok, sum_z, moment_z = rows_agree(ch, expect)
    assert ok, (readout, sum_z, moment_z)
    assert header["refrender:rollingShutter"].startswith(f"lines {readout} lineDelay 0.01")
    # planted: the global shutter, or the lines read the other way, are far outside the bounds
    assert not rows_agree(ch, expected("lines", readout, 0.0))[0]
    flipped = {"top-to-bottom": "bottom-to-top", "bottom-to-top": "top-to-bottom",
               "left-to-right": "right-to-left", "right-to-left": "left-to-right"}[readout]
    assert not rows_agree(ch, expected("lines", flipped, delay))[0]


def test_3dgs_deblur_preset_centres_the_readout_on_mid_exposure(tmp_path):
    t_ro = 0.2
    ch, header = render(tmp_path, f'rolling="3dgs-deblur" readoutTime="{t_ro}"')
    ok, sum_z, moment_z = rows_agree(ch, expected("3dgs-deblur", t_ro=t_ro))
    assert ok, (sum_z, moment_z)
    # planted: the line's time without the half line (t_ro r / H - t_ro / 2) is 0.07 pixels off
    assert not rows_agree(ch, _no_half_line(t_ro))[0]
    # its line r is the general model's with delta = t_ro / H and the windows moved back by
    # t_ro (1 - 1/H) / 2: three rows checked against that rewriting
    for r in (0, H // 2, H - 1):
        general = OPEN - t_ro * (1 - 1 / H) / 2 + (t_ro / H) * r
        assert general + (CLOSE - OPEN) / 2 == pytest.approx(0.5 * (OPEN + CLOSE) + t_ro * ((r + 0.5) / H - 0.5))
    assert not rows_agree(ch, expected("3dgs-deblur", t_ro=0.0))[0]


@pytest.mark.parametrize("readout", ["top-to-bottom", "right-to-left"])
def test_gsplat_preset_exposes_each_row_at_one_instant(tmp_path, readout):
    ch, _ = render(tmp_path, f'rolling="gsplat" readout="{readout}"')
    t = gsplat_instants(readout)
    # 3DGUT's per-row time is gsplat's (only their global shutters differ: 0 and 0.5)
    assert np.array_equal(t, gsplat_instants(readout, reference.dgut_row_instant))
    # an instant: the pixel is covered or not; a tiny window about t decides which
    hit = covered_time(t - 1e-9, t + 1e-9) > 1e-9
    got = ch["R"]
    assert np.all(ch["stderr.R"] == 0)  # every sample of a pixel is the same instant
    assert np.array_equal(got > 0.5, hit), np.argwhere((got > 0.5) != hit)
    # planted: the readout the other way round differs
    other = {"top-to-bottom": "bottom-to-top", "right-to-left": "left-to-right"}[readout]
    assert not np.array_equal(got > 0.5, covered_time(gsplat_instants(other) - 1e-9,
                                                      gsplat_instants(other) + 1e-9) > 1e-9)


SHARP_T = 0.05


def sharp_instants(kind, readout):
    """Each pixel's instant in a sharp frame at SHARP_T: every line's exposure shrunk to an instant, the
    readout kept (as the sensor records a zero-length exposure): the preset's window with [open, close]
    = [T, T], and for gsplat, whose lines are instants already and whose readout spans its shutter, the
    scene's readout (CLOSE - OPEN) begun at T."""
    r, lines = line_index(readout)
    if kind == "lines":
        return SHARP_T + 0.005 * r
    if kind == "3dgs-deblur":
        rows = np.broadcast_to(np.arange(H)[:, None], (H, W))
        t0, t1 = reference.deblur3dgs_row_window(rows, H, SHARP_T, SHARP_T, 0.2)
        assert np.array_equal(t0, t1)
        return t0
    j, i = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
    return reference.gsplat_row_instant(j, i, W, H, SHARP_T, SHARP_T + CLOSE - OPEN, readout.replace("-", "_"))


@pytest.mark.parametrize("kind, attrs, readout", [
    ("lines", 'lineDelay="0.005"', "top-to-bottom"),
    ("3dgs-deblur", 'readoutTime="0.2"', "top-to-bottom"),
    ("gsplat", "", "top-to-bottom"),
    ("gsplat", "", "right-to-left"),
])
def test_time_gives_each_line_its_instant_around_t(tmp_path, kind, attrs, readout):
    """--time T with a rolling shutter: each line at T plus its readout offset, for every preset (gsplat
    once gave every line T, and both headers said [T, T] only). With the camera moving, the sphere's
    edge in each row is where the analytic coverage at that row's instant puts it, pixel for pixel;
    the header's lineTimes states the first and last lines' instants."""
    out = tmp_path / "o.exr"
    proc = run([scene(tmp_path, f'rolling="{kind}" readout="{readout}" {attrs}'), "--time", SHARP_T,
                "--pixel-filter", "point", "--spp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    ch, header = read_full(out)
    t = sharp_instants(kind, readout)
    hit = covered_time(t - 1e-9, t + 1e-9) > 1e-9
    got = ch["R"]
    assert set(np.unique(got)) <= {0.0, 1.0}
    assert np.array_equal(got > 0.5, hit), np.argwhere((got > 0.5) != hit)
    # planted: every line at T is another image
    assert not np.array_equal(got > 0.5, covered_time(SHARP_T - 1e-9, SHARP_T + 1e-9) > 1e-9)
    assert [float(v) for v in header["refrender:shutter"].split()] == [SHARP_T, SHARP_T]
    r, lines = line_index(readout)
    windows = re.findall(r"line (\d+) \[([^,]+), ([^]]+)\]", header["refrender:lineTimes"])
    assert [int(w[0]) for w in windows] == [0, lines - 1], header["refrender:lineTimes"]
    for (_, start, end), want in zip(windows, (t[r == 0][0], t[r == lines - 1][0])):
        assert float(start) == float(end) == pytest.approx(want, rel=0, abs=1e-15)


def test_rolling_shutter_composes_with_passes_crops_and_is_in_the_identity(tmp_path):
    attrs = 'rolling="lines" lineDelay="0.01"'
    full, _ = render(tmp_path, attrs, name="full")
    p0 = tmp_path / "p0.exr"
    p1 = tmp_path / "p1.exr"
    for k, p in enumerate((p0, p1)):
        proc = run([scene(tmp_path, attrs, "full"), "--pixel-filter", "point", "--spp", 1, "--tspp", 64,
                    "--batches", 32, "--seed", 3, "--pass", f"{k}/2", "-o", p, "--quiet"])
        assert proc.returncode == 0, proc.stderr
    merged = tmp_path / "m.exr"
    assert run(["merge", p0, p1, "-o", merged, "--quiet"]).returncode == 0
    assert np.array_equal(read_full(merged)[0]["R"], full["R"])
    crop, _ = render(tmp_path, attrs, "--crop-window", "0,1,0.5,1", name="crop")
    assert np.array_equal(crop["R"], full["R"][H // 2:])
    # a state of another rolling shutter is not merged with this one
    other = tmp_path / "o.exr"
    proc = run([scene(tmp_path, 'rolling="lines" lineDelay="0.02"', "other"), "--pixel-filter", "point", "--spp", 1,
                "--tspp", 64, "--batches", 32, "--seed", 3, "--pass", "1/2", "-o", other, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    proc = run(["merge", p0, other, "-o", tmp_path / "bad.exr", "--quiet"])
    assert proc.returncode != 0 and "not the same render" in proc.stderr, proc.stderr
    assert read_full(other)[1]["refrender:rollingShutter"] != read_full(p0)[1]["refrender:rollingShutter"]


@pytest.mark.parametrize("attrs, message", [
    ('rolling="lines"', "needs lineDelay"),
    ('rolling="3dgs-deblur"', "needs readoutTime"),
    ('rolling="diagonal"', "unknown rolling shutter 'diagonal'"),
    ('rolling="lines" lineDelay="0.1" readout="sideways"', "unknown readout 'sideways'"),
    ('readout="bottom-to-top"', "'readout' is for a rolling shutter"),
    ('lineDelay="0.1"', "lineDelay is for"),
    ('rolling="gsplat" weight="linear"', "nothing to weigh"),
])
def test_bad_rolling_shutters_are_refused_by_name(tmp_path, attrs, message):
    proc = run([scene(tmp_path, attrs), "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode != 0 and message in proc.stderr, proc.stderr


def test_exact_time_refuses_a_rolling_shutter(tmp_path):
    proc = run([scene(tmp_path, 'rolling="lines" lineDelay="0.01"'), "--time-integration", "exact",
                "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode != 0 and "rolling shutter" in proc.stderr, proc.stderr


# ---- gsplat's pose between a start and an end pose ----------------------------------------------------
# A camera 20 units from the world origin turning 20 degrees while it moves 0.2 (two TUM poses at the
# shutter's ends): gsplat lerps the world-to-camera translation -R^T c and slerps the rotation
# (rolling_shutter_reference.gsplat_shutter_pose, from gsplat v1.5.3's Cameras.cuh), so the centre
# bends off the line between the poses' centres, by about u (1 - u) theta^2 / 2 x 20 = 0.3 at mid-frame.
TURN = np.radians(20.0)
P0, P1 = np.array([20.0, 0.0, 0.0]), np.array([20.2, 0.0, 0.0])
SPHERE, SPHERE_R = np.array([21.0, 0.0, 6.0]), 1.5


def turning_poses():
    """The two camera-to-world poses (OpenCV axes): (R, centre) at t = 0 and t = 1."""
    c, s = np.cos(TURN), np.sin(TURN)
    return (np.eye(3), P0), (np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]), P1)


def viewmat(R, centre):
    V = np.eye(4)
    V[:3, :3], V[:3, 3] = R.T, -R.T @ centre
    return V


SPHERE_XML = (f'<object position="{SPHERE[0]} {SPHERE[1]} {SPHERE[2]}"><sphere radius="{SPHERE_R}" color="1 1 1"/>'
              f'<material shading="unlit"/></object>')


def turning_scene(tmp_path, objects=SPHERE_XML):
    (_, c0), (_, c1) = turning_poses()
    h = TURN / 2
    (tmp_path / "turn.tum").write_text(f"0 {c0[0]!r} {c0[1]!r} {c0[2]!r} 0 0 0 1\n"
                                       f"1 {c1[0]!r} {c1[1]!r} {c1[2]!r} 0 {np.sin(h)!r} 0 {np.cos(h)!r}\n")
    xml = (f'<scene><camera fov="{FOV}" width="{W}" height="{H}"><trajectory file="turn.tum" axes="opencv"/></camera>'
           f'<shutter open="0" close="1" rolling="gsplat"/><background color="0 0 0"/>{objects}</scene>')
    p = tmp_path / "turn.xml"
    p.write_text(xml)
    return p


def sphere_hits(pose_at):
    """Per pixel (H x W): whether the ray through its centre, from the pose of its row's relative
    time u = row / (H - 1) (top to bottom), meets the sphere; and how far from grazing it is."""
    f = H / (2 * np.tan(np.radians(FOV) / 2))
    hit, margin = np.zeros((H, W), bool), np.zeros((H, W))
    for row in range(H):
        R, centre = pose_at(row / (H - 1))
        for col in range(W):
            d = R @ np.array([(col + 0.5 - W / 2) / f, (row + 0.5 - H / 2) / f, 1.0])
            d /= np.linalg.norm(d)
            w = SPHERE - centre
            miss = np.sqrt(max(0.0, w @ w - (w @ d) ** 2))
            hit[row, col], margin[row, col] = miss <= SPHERE_R and w @ d > 0, abs(miss - SPHERE_R)
    return hit, margin


def test_the_gsplat_preset_moves_a_turning_camera_as_gsplat_interpolates_its_two_poses(tmp_path):
    (R0, c0), (R1, c1) = turning_poses()

    def gsplat(u):
        R_w2c, _, centre = reference.gsplat_shutter_pose(viewmat(R0, c0), viewmat(R1, c1), u)
        return R_w2c.T, centre

    def centre_lerped(u):  # refrender's rule before: the trajectory's own linear pose
        return gsplat(u)[0], (1 - u) * c0 + u * c1

    expect, margin = sphere_hits(gsplat)
    out = tmp_path / "turn.exr"
    proc = run([turning_scene(tmp_path), "--pixel-filter", "point", "--spp", 1, "--tspp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    got = read_full(out)[0]["R"] > 0.5
    assert margin.min() > 1e-6  # no pixel's ray grazes the sphere
    assert expect.sum() > 100 and np.array_equal(got, expect), int((got != expect).sum())
    # the old rule draws another image: the centre lerped misses or hits the sphere elsewhere
    assert (sphere_hits(centre_lerped)[0] != expect).sum() > 10


def test_the_gsplat_preset_takes_every_gaussians_sh_direction_from_the_two_poses_mean_centre(tmp_path):
    """gsplat evaluates each Gaussian's SH once, from the mean of the start and end poses' centres
    (rolling_shutter_reference.gsplat_sh_campos, rendering.py:491-494), whatever the row's pose. One
    3DGS Gaussian of SH degree 1 over black: every pixel's RGB / A is its colour (alpha c + 0 (1 -
    alpha), A = alpha), the same in every row; from each row's own centre it would change by
    about 0.01 from row to row."""
    import gs3d_raster_reference as gs3d
    import gsply
    (R0, c0), (R1, c1) = turning_poses()
    sh = np.array([[[0.2, 0.1, -0.3], [1.5, -1.0, 0.5], [-0.5, 1.2, 0.8], [1.0, 0.6, -1.4]]])
    model = {"mean": SPHERE[None, :], "scale": np.full((1, 3), 0.4), "rot": np.array([[1.0, 0, 0, 0]]),
             "opacity": np.array([0.9]), "sh": sh}
    gsply.write(tmp_path / "g.ply", model)
    scene = turning_scene(tmp_path, '<object name="g"><gaussianModel file="g.ply" semantics="gsplat"/></object>')
    out = tmp_path / "g.exr"
    proc = run([scene, "--pixel-filter", "point", "--spp", 1, "--tspp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    ch = read_full(out)[0]
    seen = ch["A"] > 0.05
    colour = np.stack([ch[c][seen] / ch["A"][seen] for c in "RGB"], axis=-1)
    campos = reference.gsplat_sh_campos(viewmat(R0, c0), viewmat(R1, c1))
    d = SPHERE - campos
    expect = gs3d.sh_colour(sh[0], 1, d / np.linalg.norm(d))
    assert seen.sum() > 100 and np.abs(colour - expect).max() < 1e-5, np.abs(colour - expect).max()
    # planted: the SH from the first or the last row's centre differs by far more
    for u in (0.0, 1.0):
        _, _, centre = reference.gsplat_shutter_pose(viewmat(R0, c0), viewmat(R1, c1), u)
        d = SPHERE - centre
        assert np.abs(gs3d.sh_colour(sh[0], 1, d / np.linalg.norm(d)) - expect).max() > 1e-3
