"""semantics="3dgs-fov-minus-one": what fudan-zvg/4d-gaussian-splatting (63725f21) draws for a
transforms.json camera with fl_x, fl_y, cx, cy (N3V/DyNeRF), whose rasterizer is handed FoV = -1
(scene/dataset_readers.py:275-293, gaussian_renderer/__init__.py:34-35): sharp renders against
tests/gs3d_raster_reference.py with rasterizer_tan_fov = (tan(-0.5), tan(-0.5)), written from that
commit's CUDA (rasterizer_impl.cu:235-236, forward.cu:206-216) without reading refrender's C. Every
pixel within 1e-4 (a converted 4DGS checkpoint too, against tests/fdgs_reference.py handed the same),
as test_gaussian_raster.py (float CUDA against double arithmetic: the reference
is float64, refrender double with float storage).

What must change is the footprint (its Jacobian pinned: the reference with the camera's own tan_fov,
i.e. `3dgs`, differs by far more than the tolerance); what must not is the mean's projection (the
reference that also projects the mean with the pinned focal length differs by far more), the near
cull at view depth 0.2 (an opaque Gaussian at 0.19 stays invisible) and the SH direction (degree 3).
The BVH must find every pixel the pinned footprint reaches: under a camera that turns and travels
(transforms.json) while the Gaussians move (<linear>), row r of a sharp frame under a `lines`
rolling shutter is the reference at the instant r / (H - 1), brute force over all Gaussians and
pixels; the view is wide and flat (the pinned focal 4 times the camera's), where a reach of the
camera's own Jacobian is too short: boxes built with gaussian_view_stretch instead of the pinned
stretch miss 11 pixels of this test (planted in accel_build.c; tests/test_gaussian_hit.c shows the
same for the bounds themselves). On a camera of N3V's
shape the mode changes the image by about what GAUSSIANS.md reports between refrender and the
official images (0.24-0.47). 2D models refuse it."""
import math

import numpy as np
import pytest

import gs3d_raster_reference as ref
import gsply
from gsply import rotation
from conftest import read_exr, run, sharp_gaussian_render
from test_gaussian_raster import BACKGROUND, TOL, assert_matches, cameras_json, random_model
from test_gs2d_filter_reach import quat_of, turned_y, two_pose_transforms_json
import fdgs_reference as fdgs
import test_fdgs as fdgs_test

PINNED = (math.tan(-0.5), math.tan(-0.5))
SEMANTICS = "3dgs-fov-minus-one"


def render(tmp_path, model, R, C, fx, fy, W, H, semantics=SEMANTICS, tile_rule=False):
    ply = tmp_path / "model.ply"
    gsply.write(ply, model)
    attrs = f' kind="3dgs" semantics="{semantics}"' + (' tileRule="on"' if tile_rule else "")
    return sharp_gaussian_render(tmp_path, cameras_json(tmp_path, R, C, fx, fy, W, H), ply, attrs), gsply.read(ply)


@pytest.mark.parametrize("tile_rule", [False, True])
@pytest.mark.parametrize("turn", [(0.0, 0.0, 0.0), (0.35, -0.25, 0.4)])
def test_a_sharp_render_is_the_rasterizer_handed_fov_minus_one(tmp_path, turn, tile_rule):
    R = rotation(*turn)
    C = -4.0 * R[:, 2]
    fx, fy, W, H = 30.0, 34.0, 40, 36
    model = random_model(71, 60, 3, sub_pixel=12)
    # an opaque Gaussian just inside the near cull (view depth 0.19) on the axis: culled as in_frustum culls
    model["mean"] = np.vstack([model["mean"], C + 0.19 * R[:, 2]])
    model["scale"] = np.vstack([model["scale"], [0.05, 0.05, 0.05]])
    model["rot"] = np.vstack([model["rot"], [1.0, 0, 0, 0]])
    model["opacity"] = np.append(model["opacity"], 0.99)
    model["sh"] = np.concatenate([model["sh"], np.full((1, 16, 3), 2.0)])
    img, read = render(tmp_path, model, R, C, fx, fy, W, H, tile_rule=tile_rule)
    expect, final_t = ref.render(read, R, C, fx, fy, W, H, BACKGROUND, "inria", tile_rule, rasterizer_tan_fov=PINNED)
    assert_matches(img, expect, final_t)
    assert (final_t < 0.5).sum() > 40
    # the footprint changes: the camera's own Jacobian (3dgs) draws another image
    true_jacobian = ref.render(read, R, C, fx, fy, W, H, BACKGROUND, "inria", tile_rule)[0]
    assert np.abs(true_jacobian - expect).max() > 100 * TOL
    # the mean's projection does not: projecting it with the pinned focal length too is far off
    f_pinned = W / (2 * abs(PINNED[0])), H / (2 * abs(PINNED[1]))
    moved = ref.render(read, R, C, *f_pinned, W, H, BACKGROUND, "inria", tile_rule, rasterizer_tan_fov=PINNED)[0]
    assert np.abs(moved - expect).max() > 100 * TOL
    # nor the near cull: the reference without it shows the Gaussian at 0.19
    near = ref.INRIA_NEAR
    try:
        ref.INRIA_NEAR = 0.1
        uncut = ref.render(read, R, C, fx, fy, W, H, BACKGROUND, "inria", tile_rule, rasterizer_tan_fov=PINNED)[0]
    finally:
        ref.INRIA_NEAR = near
    assert np.abs(uncut - expect).max() > 100 * TOL


def test_a_4dgs_checkpoint_is_the_official_renderer_on_an_n3v_camera(tmp_path):
    """A real-time 4DGS checkpoint (tests/test_fdgs.py's: moving, fading, degree-3 4D SH) through the
    converter, sharp instants against tests/fdgs_reference.py handed tan(-0.5): what train.py showed
    while training on N3V."""
    W, H = 64, 48
    R, C, f = fdgs_test.camera(W, H)
    capture = fdgs_test.mixed_capture()
    convention = fdgs.CONVENTIONS[0]
    scene = fdgs_test.write_scene(tmp_path, capture, convention, R, C, f, W, H, BACKGROUND)
    scene.write_text(scene.read_text().replace("<gaussianModel ", f'<gaussianModel semantics="{SEMANTICS}" '))
    for t in fdgs_test.SHARP_TIMES[:2]:
        img = read_exr(fdgs_test.render(scene, tmp_path / f"sharp{t}.exr", "--time", t))[0]
        expect, final_t = fdgs.render_instant(capture, t, convention, fdgs_test.TIME_DURATION, R, C, f, f, W, H,
                                              BACKGROUND, rasterizer_tan_fov=PINNED)
        assert_matches(img, expect, final_t)
        camera_own = fdgs.render_instant(capture, t, convention, fdgs_test.TIME_DURATION, R, C, f, f, W, H,
                                         BACKGROUND)[0]
        assert np.abs(camera_own - expect).max() > 100 * TOL


# ---- moving camera and moving Gaussians: the swept reach -------------------------------------------
# A wide, flat view: the pinned focal 0.915 W = 36.6 is 4 times MF, and the pinned Jacobian stretches
# 1.6 times as far as the camera's own could (gaussian_view_stretch: the image's width dominates both)
MW, MH, MF = 40, 12, 9.0
TURN = 8.0                      # degrees about the camera's y axis over the shutter
TRAVEL = np.array([0.12, -0.05, 0.08])
VELOCITY = np.array([-0.1, 0.06, 0.03])  # the object's <linear> velocity, per unit of time


def pose(t):
    """The camera (OpenCV camera-to-world rotation, centre) at time t: two poses at 0 and 1, the
    position lerped, the rotation (about one axis) its angle lerped."""
    return turned_y(TURN * (t - 0.5)), TRAVEL * t


def pinned_widest(W, H):
    """The camera-space direction the pinned Jacobian J = diag(a, b) / z [[1, 0, -t], [0, 1, -t]]
    stretches most (a = W / (2 tan(-0.5)), b likewise with H, t = 1.3 tan(-0.5): forward.cu:206-216,
    rasterizer_impl.cu:235-236): J^T u, u the top eigenvector of J J^T."""
    a, b, t = W / (2 * PINNED[0]), H / (2 * PINNED[1]), 1.3 * PINNED[0]
    JJ = np.array([[a * a * (1 + t * t), a * b * t * t], [a * b * t * t, b * b * (1 + t * t)]])
    u = np.linalg.eigh(JJ)[1][:, 1]
    d = np.array([a * u[0], b * u[1], -t * (a * u[0] + b * u[1])])
    return d / np.linalg.norm(d)


def moving_model(seed, n=60):
    """Gaussians over the whole view and just beyond its edges at depths 2.5 to 4: half of them
    ellipsoids 1 to 3 pixels wide (under the camera's focal length), half needles (scales s, s/100,
    s/100) along the pinned Jacobian's widest direction at mid-shutter, opacity 0.99, whose footprints
    reach farther than the camera's own Jacobian could stretch them."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(2.5, 4.0, n)
    ang = rng.uniform(-1.2, 1.2, (n, 2)) * np.array([MW / 2, MH / 2]) / MF
    R, C = pose(0.5)
    mean = (R @ np.stack([ang[:, 0] * z, ang[:, 1] * z, z])).T + C
    q = rng.normal(size=(n, 4))
    rot = q / np.linalg.norm(q, axis=1)[:, None]
    scale = rng.uniform(1.0, 3.0, (n, 3)) * z[:, None] / MF
    opacity = rng.uniform(0.3, 0.95, n)
    d = R @ pinned_widest(MW, MH)
    e = np.cross(d, [0.0, 1.0, 0.0])
    e /= np.linalg.norm(e)
    rot[n // 2:] = quat_of(np.stack([d, e, np.cross(d, e)], axis=1))
    scale[n // 2:] = np.outer(rng.uniform(0.5, 2.0, n - n // 2) * z[n // 2:] / MF, [1.0, 0.01, 0.01])
    opacity[n // 2:] = 0.99
    return {"mean": mean, "scale": scale, "rot": rot, "opacity": opacity, "sh": rng.normal(0, 0.4, (n, 1, 3)),
            "degree": 0}


def test_a_moving_camera_and_moving_gaussians_find_every_pinned_footprint_pixel(tmp_path):
    model = moving_model(6)
    ply = tmp_path / "m.ply"
    gsply.write(ply, model)
    read = gsply.read(ply)
    two_pose_transforms_json(tmp_path / "transforms.json", pose, MF, MW / 2, MH / 2, MW, MH)
    scene = tmp_path / "moving.xml"
    v = " ".join(map(repr, VELOCITY))
    scene.write_text('<scene><camera><trajectory file="transforms.json"/></camera>'
                     f'<shutter open="0" close="1" rolling="lines" lineDelay="{1 / (MH - 1)!r}"/>'
                     '<background color="0.1 0.2 0.3"/>'
                     f'<object name="g"><animation><linear velocity="{v}"/></animation>'
                     f'<gaussianModel file="{ply}" semantics="{SEMANTICS}"/></object></scene>')
    out = tmp_path / "moving.exr"
    proc = run([scene, "--pixel-filter", "point", "--time", 0, "--spp", 1, "--tspp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    img = read_exr(out)[0]
    expect = np.zeros((MH, MW, 3))
    true_jacobian = np.zeros((MH, MW, 3))
    for r in range(MH):
        t = r / (MH - 1)
        R, C = pose(t)
        moved = dict(read, mean=np.asarray(read["mean"], np.float64) + VELOCITY * t)
        expect[r] = ref.render(moved, R, C, MF, MF, MW, MH, BACKGROUND, rasterizer_tan_fov=PINNED)[0][r]
        if r in (0, MH // 2, MH - 1):
            true_jacobian[r] = ref.render(moved, R, C, MF, MF, MW, MH, BACKGROUND)[0][r]
    rows = [0, MH // 2, MH - 1]
    assert np.abs(true_jacobian[rows] - expect[rows]).max() > 100 * TOL
    err = np.abs(img[..., :3] - expect).max(axis=2)
    assert err.max() < TOL, (int((err >= TOL).sum()), float(err.max()))


# ---- how much the mode changes an N3V-like image ---------------------------------------------------
def test_on_a_camera_of_n3v_shape_the_pinned_jacobian_changes_the_image_as_documented(tmp_path):
    """N3V's cameras (1352 x 1014 at 4DGS's resolution, fl_x about 0.54 W: 85 degrees) scaled to 68 x
    51; a dense random scene of 400 Gaussians 0.5 to 3 pixels wide, as a trained model's. The pinned
    Jacobian's footprints are about 1.7 times wider (0.915 W against 0.54 W), so the image changes by
    about the 0.24-0.47 measured between refrender and the official images of N3V models."""
    W, H = 68, 51
    f = 0.54 * W
    rng = np.random.default_rng(9)
    n = 400
    z = rng.uniform(2.0, 6.0, n)
    ang = rng.uniform(-1.1, 1.1, (n, 2)) * np.array([W / 2, H / 2]) / f
    q = rng.normal(size=(n, 4))
    model = {"mean": np.stack([ang[:, 0] * z, ang[:, 1] * z, z], axis=1),
             "scale": rng.uniform(0.5, 3.0, (n, 3)) * z[:, None] / f, "rot": q / np.linalg.norm(q, axis=1)[:, None],
             "opacity": rng.uniform(0.3, 0.99, n), "sh": rng.normal(0, 0.6, (n, 1, 3)), "degree": 0}
    R, C = np.eye(3), np.zeros(3)
    pinned, read = render(tmp_path, model, R, C, f, f, W, H)
    camera = render(tmp_path, model, R, C, f, f, W, H, semantics="3dgs")[0]
    diff = np.abs(pinned[..., :3] - camera[..., :3]).max(axis=2)
    print(f"max {diff.max():.3f}, 99th percentile {np.percentile(diff, 99):.3f}, mean {diff.mean():.3f}")
    assert 0.24 <= diff.max() <= 1.0
    expect, final_t = ref.render(read, R, C, f, f, W, H, BACKGROUND, rasterizer_tan_fov=PINNED)
    assert_matches(pinned, expect, final_t)


@pytest.mark.parametrize("kind", ["2dgs"])
def test_a_2d_model_refuses_it_naming_the_file_and_line(tmp_path, kind):
    ply = tmp_path / "s.ply"
    gsply.write(ply, {"mean": np.zeros((1, 3)), "scale": np.full((1, 2), 0.1), "rot": np.array([[1.0, 0, 0, 0]]),
                      "opacity": np.array([0.5]), "sh": np.zeros((1, 1, 3)), "degree": 0})
    scene = tmp_path / "s.xml"
    scene.write_text('<scene>\n<object name="g">\n'
                     f'<gaussianModel file="{ply}" kind="{kind}" semantics="{SEMANTICS}"/></object></scene>')
    proc = run([scene, "-o", tmp_path / "s.exr", "--quiet"])
    assert proc.returncode != 0 and not (tmp_path / "s.exr").exists()
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{scene}:3" in lines[0] and "2dgs, 2dgs-center-near or 2dgs-unit-circle" in lines[0], lines
