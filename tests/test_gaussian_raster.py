"""3D Gaussians as their rasterizers draw them: sharp renders
(--pixel-filter point, one --time, one sample) against
tests/gs3d_raster_reference.py, an independent numpy reference of
graphdeco-inria diff-gaussian-rasterization (9c5c202, dr_aa, and its
`antialiasing` flag) and nerfstudio gsplat v1.5.3, written by a helper
session from the CUDA sources without seeing refrender's C. Every pixel
within 1e-4 (float against double arithmetic).

Scenes: SH degree 0 and 3; overlapping anisotropic Gaussians; sub-pixel
ones (the 0.3 dilation dominates); Gaussians off screen beyond the
Jacobian's 1.3 tan(fov/2) clamp whose tails reach in; fx != fy (a
cameras.json camera); a turned camera; wide lenses (60 to 140 degrees)
with Gaussians far off axis, where the reference, which evaluates every
Gaussian at every pixel, is the brute-force check that no Gaussian with
alpha >= 1/255 is missed. Each rule under test is first checked to matter
on its scene: the reference changed in that rule differs by far more than
the tolerance."""
import json

import numpy as np
import pytest

import gs3d_raster_reference as ref
import gsply
from gsply import rotation
from conftest import read_exr, run, sharp_gaussian_render

BACKGROUND = (0.1, 0.2, 0.3)
TOL = 1e-4
# refrender's semantics -> the reference's variant
VARIANT = {"3dgs": "inria", "3dgs-antialiased": "inria-antialiased", "gsplat": "gsplat",
           "gsplat-antialiased": "gsplat-antialiased"}


def random_model(seed, n, degree, sub_pixel=0, spread=0.7, opacity=(0.2, 0.95)):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    m = {"mean": rng.uniform(-spread, spread, (n, 3)), "scale": rng.uniform(0.02, 0.3, (n, 3)),
         "rot": q / np.linalg.norm(q, axis=1)[:, None], "opacity": rng.uniform(*opacity, n),
         "sh": rng.normal(0, 0.4, (n, (degree + 1) ** 2, 3)), "degree": degree}
    m["scale"][:sub_pixel] = rng.uniform(1e-4, 3e-3, (sub_pixel, 3))
    return m


def cameras_json(tmp_path, R, C, fx, fy, W, H):
    path = tmp_path / "cameras.json"
    path.write_text(json.dumps([{"id": 0, "img_name": "view", "width": W, "height": H,
                                 "position": list(map(float, C)),
                                 "rotation": [list(map(float, row)) for row in R], "fx": fx, "fy": fy}]))
    return f'<camera cameras="{path}" image="view"/>'


def render_pair(tmp_path, model, R, C, fx, fy, W, H, semantics="3dgs", tile_rule=False, extra=""):
    """refrender's image and the reference's, for the model as its PLY stores it."""
    ply = tmp_path / "model.ply"
    gsply.write(ply, model)
    camera = cameras_json(tmp_path, R, C, fx, fy, W, H)
    attrs = f' kind="3dgs" semantics="{semantics}"' + (' tileRule="on"' if tile_rule else "") + extra
    img = sharp_gaussian_render(tmp_path, camera, ply, attrs)
    read = gsply.read(ply)
    expect, final_t = ref.render(read, R, C, fx, fy, W, H, BACKGROUND, VARIANT[semantics], tile_rule)
    return img, expect, final_t, read


def assert_matches(img, expect, final_t):
    err = np.abs(img[..., :3] - expect)
    assert err.max() < TOL, (err.max(), np.unravel_index(err.argmax(), err.shape))
    assert np.abs(img[..., 3] - (1 - final_t)).max() < TOL


def with_constant(name, value, fn):
    """The reference with one of its constants changed (a planted error, to show the scene is sensitive)."""
    old = getattr(ref, name)
    setattr(ref, name, value)
    try:
        return fn()
    finally:
        setattr(ref, name, old)


CAMERAS = [(0.0, 0.0, 0.0), (0.35, -0.25, 0.4)]


@pytest.mark.parametrize("degree", [0, 3])
@pytest.mark.parametrize("turn", CAMERAS)
def test_a_sharp_render_is_the_official_3dgs_rasterizer(tmp_path, degree, turn):
    R = rotation(*turn)
    C = -4.0 * R[:, 2]
    model = random_model(31 + degree, 60, degree, sub_pixel=12)
    img, expect, final_t, read = render_pair(tmp_path, model, R, C, 45.0, 52.0, 40, 36)
    assert_matches(img, expect, final_t)
    assert (final_t < 0.5).sum() > 40
    # the dilation matters here (sub-pixel Gaussians are drawn through it)
    no_dilation = with_constant("EPS2D", 1e-9, lambda: ref.render(read, R, C, 45.0, 52.0, 40, 36, BACKGROUND)[0])
    assert np.abs(no_dilation - expect).max() > 100 * TOL


@pytest.mark.parametrize("semantics", ["3dgs-antialiased", "gsplat", "gsplat-antialiased"])
def test_the_variants_are_their_rasterizers(tmp_path, semantics):
    R = rotation(0.2, 0.15, -0.3)
    C = -4.0 * R[:, 2]
    model = random_model(41, 60, 3, sub_pixel=15)
    model["mean"][-1], model["scale"][-1], model["opacity"][-1] = -R[:, 2], 0.4, 0.999  # gsplat's 0.999 cap shows
    img, expect, final_t, read = render_pair(tmp_path, model, R, C, 50.0, 44.0, 36, 40, semantics)
    assert_matches(img, expect, final_t)
    classic = ref.render(read, R, C, 50.0, 44.0, 36, 40, BACKGROUND, "inria")[0]
    assert np.abs(classic - expect).max() > 10 * TOL  # each variant draws another image


def off_axis_model(seed, fov_x, fx, n=40):
    """Gaussians spread over the whole view at depths 1.5 to 5, and half of them just beyond its left
    and right edges (outside the 1.3 tan(fov/2) clamp), 2 to 5 pixels wide, their tails reaching in."""
    rng = np.random.default_rng(seed)
    t = np.tan(np.radians(fov_x) / 2)
    z = rng.uniform(1.5, 5.0, n)
    ang = rng.uniform(-t, t, (n, 2))
    ang[: n // 2, 0] = rng.choice([-1, 1], n // 2) * rng.uniform(1.32 * t, 1.45 * t, n // 2)
    q = rng.normal(size=(n, 4))
    return {"mean": np.stack([ang[:, 0] * z, 0.7 * ang[:, 1] * z, z], axis=1),
            "scale": rng.uniform(2.0, 5.0, (n, 3)) * z[:, None] / fx, "rot": q / np.linalg.norm(q, axis=1)[:, None],
            "opacity": rng.uniform(0.5, 0.99, n), "sh": rng.normal(0, 0.4, (n, 1, 3)), "degree": 0}


@pytest.mark.parametrize("fov_x", [60, 100, 140])
@pytest.mark.parametrize("semantics", ["3dgs", "gsplat-antialiased"])
def test_no_gaussian_is_missed_by_wide_lenses_far_off_axis(tmp_path, fov_x, semantics):
    W, H = 48, 32
    fx = W / (2 * np.tan(np.radians(fov_x) / 2))
    model = off_axis_model(fov_x, fov_x, fx)
    img, expect, final_t, read = render_pair(tmp_path, model, np.eye(3), np.zeros(3), fx, 1.1 * fx, W, H, semantics)
    assert_matches(img, expect, final_t)
    # Gaussians beyond the clamp are drawn: the image without them differs
    x_over_z = read["mean"][:, 0] / read["mean"][:, 2]
    outside = np.abs(x_over_z) > 1.3 * W / (2 * fx)
    assert outside.sum() >= 5
    kept = {k: (v[~outside] if k != "degree" else v) for k, v in read.items()}
    without = ref.render(kept, np.eye(3), np.zeros(3), fx, 1.1 * fx, W, H, BACKGROUND, VARIANT[semantics])[0]
    assert np.abs(without - expect).max() > 100 * TOL


def test_the_tile_rule_draws_what_the_rasterizer_draws_and_cuts_tails(tmp_path):
    """tileRule="on": only in the 16x16 tiles the 3-sigma radius touches; opaque Gaussians' tails beyond
    it (alpha >= 1/255 up to 3.33 sigma) are cut, as in the official image."""
    W, H = 64, 48
    R, C = np.eye(3), np.array([0.0, 0.0, -4.0])
    model = random_model(51, 30, 0, opacity=(0.9, 0.99))
    model["scale"] = np.full((30, 3), 0.06)  # round ones: their 3-sigma radius is ~4 pixels
    img, expect, final_t, read = render_pair(tmp_path, model, R, C, 60.0, 60.0, W, H, tile_rule=True)
    assert_matches(img, expect, final_t)
    untiled = ref.render(read, R, C, 60.0, 60.0, W, H, BACKGROUND, "inria")[0]
    assert np.abs(untiled - expect).max() > 10 * TOL


def test_3dgrt_is_kept_under_its_name_and_differs_from_the_rasterizer(tmp_path):
    import gs3d_grt_reference as grt
    R = rotation(0.3, -0.2)
    C = -4.0 * R[:, 2]
    model = random_model(61, 40, 0)
    img, raster, final_t, read = render_pair(tmp_path, model, R, C, 45.0, 45.0, 32, 32, "3dgs")
    scene = tmp_path / "grt.xml"
    scene.write_text((tmp_path / "scene.xml").read_text().replace('semantics="3dgs"', 'semantics="3dgrt"'))
    out = tmp_path / "grt.exr"
    assert run([scene, "--pixel-filter", "point", "--time", 0, "--spp", 1, "-o", out, "--quiet"]).returncode == 0
    traced = grt.render(read, R, C, 45.0, 45.0, 32, 32, BACKGROUND)[0]
    assert np.abs(read_exr(out)[0][..., :3] - traced).max() < TOL
    assert np.abs(traced - raster).max() > 0.02  # the two formations draw visibly different images


@pytest.mark.parametrize("attrs,why", [
    ('kind="3dgs" semantics="2dgs"', "semantics for a 3D model must be 3dgs, 3dgs-antialiased, 3dgs-fov-minus-one, gsplat"),
    ('kind="2dgs" semantics="3dgs"', "semantics for a 2D model must be 2dgs, 2dgs-center-near or 2dgs-unit-circle"),
    ('kind="3dgs" semantics="3dgrt" tileRule="on"', "3DGRT traces rays and has no tiles"),
    ('kind="3dgs" tileRule="yes"', "tileRule must be on or off"),
])
def test_semantics_mistakes_are_named(tmp_path, attrs, why):
    ply = tmp_path / "m.ply"
    gsply.write(ply, random_model(1, 2, 0))
    scene = tmp_path / "bad.xml"
    scene.write_text(f'<scene><camera position="0 0 -4" lookat="0 0 0" up="0 1 0" fov="40" width="8" height="8"/>'
                     f'<object name="g">\n<gaussianModel file="{ply}" {attrs}/></object></scene>')
    proc = run([scene, "--time", 0, "-o", tmp_path / "x.exr", "--quiet"])
    assert proc.returncode != 0 and why in proc.stderr and "bad.xml:2" in proc.stderr, proc.stderr


# ---- a principal point off the image centre (a transforms.json camera) ----

OFF_W, OFF_H, OFF_FX, OFF_FY, OFF_CX, OFF_CY = 48, 36, 40.0, 44.0, 10.0, 28.0  # 14 px left of centre, 10 px below


def transforms_camera(tmp_path, R, C, fx=OFF_FX, fy=OFF_FY, cx=OFF_CX, cy=OFF_CY):
    """The <camera> of a nerfstudio transforms.json of OFF_W x OFF_H pixels with that principal point:
    its transform_matrix is camera-to-world in OpenGL axes (the OpenCV rotation's y and z columns negated)."""
    c2w = np.eye(4)
    c2w[:3, :3], c2w[:3, 3] = R @ np.diag([1.0, -1.0, -1.0]), C
    doc = {"camera_model": "PINHOLE", "fl_x": fx, "fl_y": fy, "cx": cx, "cy": cy, "w": OFF_W,
           "h": OFF_H, "frames": [{"file_path": f"{i}.png", "transform_matrix": c2w.tolist()} for i in range(2)]}
    path = tmp_path / "transforms.json"
    path.write_text(json.dumps(doc))
    return f'<camera><trajectory file="{path}"/></camera>'


# (x/z, y/z) of single Gaussians between the old clamp (+-1.3 cx/fx, +-1.3 cy/fy = +-0.325, +-0.827)
# and each rasterizer's: gsplat's x/z in [-0.43, 1.13], y/z in [-0.759, 0.3045] (0.3 tan(fov/2) past
# each image edge), Inria's +-0.78, +-0.532 (1.3 tan(fov/2) about the axis). Two in the image, two
# off it whose tails reach in.
OFF_CENTRE_GAUSSIANS = [((0.9, 0.0), 3.0, (0.25, 0.05, 0.05)), ((-0.38, -0.2), 2.0, (0.5, 0.3, 0.1)),
                        ((0.0, 0.6), 2.5, (0.3, 0.8, 0.2)), ((0.3, -0.8), 2.0, (0.2, 0.5, 0.3))]


def old_clamp(family, x, y, z, fx, fy, W, H, cx, cy):
    """The clamp refrender had, +-1.3 cx/fx and +-1.3 cy/fy whatever the semantics (a planted error)."""
    lx, ly = 1.3 * cx / fx, 1.3 * cy / fy
    return min(lx, max(-lx, x / z)), min(ly, max(-ly, y / z))


@pytest.mark.parametrize("semantics", ["gsplat", "gsplat-antialiased", "3dgs", "3dgs-antialiased"])
@pytest.mark.parametrize("case", range(len(OFF_CENTRE_GAUSSIANS)))
def test_an_off_centre_principal_point_clamps_as_each_rasterizer_does(tmp_path, semantics, case):
    """gsplat v1.5.3 clamps the Jacobian's x/z to [-(cx/fx + 0.3 tan), (W - cx)/fx + 0.3 tan], tan =
    W / (2 fx), y likewise (persp_proj, 937e299 gsplat/cuda/include/Utils.cuh:514-524); Inria's
    rasterizer has no principal point and its clamp, +-1.3 tan_fovx about the optical axis
    (forward.cu:82-87), is kept (GAUSSIANS.md; the reference's inria_off_centre_extension: an
    off-centre projection matrix handed to Inria's CUDA). A single Gaussian between the old and the
    new limit, rendered through a transforms.json camera, is the reference's within 1e-4."""
    (tx, ty), z, scale = OFF_CENTRE_GAUSSIANS[case]
    R, C = rotation(0.1, -0.05, 0.2), np.array([0.3, -0.2, -1.0])
    rng = np.random.default_rng(71 + case)
    q = rng.normal(size=4)
    model = {"mean": (C + R @ np.array([tx * z, ty * z, z]))[None], "scale": np.array([scale]),
             "rot": (q / np.linalg.norm(q))[None], "opacity": np.array([0.9]), "sh": rng.normal(0, 0.4, (1, 1, 3)),
             "degree": 0}
    ply = tmp_path / "model.ply"
    gsply.write(ply, model)
    img = sharp_gaussian_render(tmp_path, transforms_camera(tmp_path, R, C), ply, f' kind="3dgs" semantics="{semantics}"')
    read = gsply.read(ply)
    render = lambda: ref.render(read, R, C, OFF_FX, OFF_FY, OFF_W, OFF_H, BACKGROUND, VARIANT[semantics],
                                cx=OFF_CX, cy=OFF_CY, inria_off_centre_extension=True)
    expect, final_t = render()
    assert_matches(img, expect, final_t)
    assert (final_t < 1 - 0.05).sum() > 20  # the Gaussian is drawn in the image
    old = with_constant("jacobian_tangents", old_clamp, render)[0]
    assert np.abs(old - expect).max() > 10 * TOL  # and the old clamp draws it otherwise


@pytest.mark.parametrize("semantics", ["gsplat", "gsplat-antialiased"])
def test_an_off_centre_needle_beyond_the_clamp_is_drawn_to_the_end_of_its_tail(tmp_path, semantics):
    """The cull's reach follows the widest clamp. fx = fy = 40 (no slack from their ratio), principal
    point (10, 28): gsplat clamps x/z to [-0.43, 1.13] and y/z to [-0.835, 0.335] (persp_proj,
    Utils.cuh:514-524). A needle whose mean lies beyond the right and top limits, at (1.2, -0.9) z, along
    the direction the clamped Jacobian stretches most, (t_x, t_y, -(t_x^2 + t_y^2)), opacity 0.99, draws
    a tail 8 px a sigma into the image down to alpha 1/255. A reach from the old clamp (+-1.3 cx/fx,
    +-1.3 cy/fy) bounds the footprint by sqrt(1 + 0.325^2 + 0.91^2) / sqrt(1 + 1.13^2 + 0.835^2) = 0.81
    of it and loses the tail beyond 0.81 x 3.32 sigma (alpha up to 0.03)."""
    f, cx, cy, z = 40.0, 10.0, 28.0, 2.0
    t = np.array([1.13, -0.835])
    d = np.array([t[0], t[1], -(t @ t)])
    d /= np.linalg.norm(d)
    # the rotation taking the Gaussian's x axis to d: quaternion (1 + d.x, 0, -d.z, d.y), normalised
    q = np.array([1 + d[0], 0.0, -d[2], d[1]])
    sigma = 8.0 / (f / z * np.sqrt(1 + t @ t))  # 8 px along the major axis
    model = {"mean": np.array([[1.2 * z, -0.9 * z, z]]), "scale": np.array([[sigma, sigma / 4, sigma / 4]]),
             "rot": (q / np.linalg.norm(q))[None], "opacity": np.array([0.99]), "sh": np.full((1, 1, 3), 1.5),
             "degree": 0}
    ply = tmp_path / "model.ply"
    gsply.write(ply, model)
    R, C = np.eye(3), np.zeros(3)
    camera = transforms_camera(tmp_path, R, C, f, f, cx, cy)
    img = sharp_gaussian_render(tmp_path, camera, ply, f' kind="3dgs" semantics="{semantics}"')
    expect, final_t = ref.render(gsply.read(ply), R, C, f, f, OFF_W, OFF_H, BACKGROUND, VARIANT[semantics], cx=cx,
                                 cy=cy)
    assert_matches(img, expect, final_t)
    assert ((final_t < 1 - 1 / 255) & (final_t > 1 - 0.03)).sum() > 30  # the tail's end is in the image
