"""2DGS renders against the independent numpy reference of the official
forward pass (tests/gs2d_reference.py, written from the paper and the
official CUDA source, not from refrender's C): with --pixel-filter point
(the rasterizer's pixel centres), one time (--time) and one sample, every
pixel must agree within 1e-4 (float against double arithmetic) on models
with SH degree 0 and 3, overlapping tilted surfels, sub-pixel surfels and a
rotated camera.

Each scene is first checked to be one where the rules under test matter:
the reference itself, changed in one rule (no low-pass filter; hit-depth
order; SH rest coefficients read point-major), differs from it by far more
than the tolerance, so a renderer with that error fails the comparison."""
import numpy as np
import pytest

import gs2d_reference as ref
import gsply
from gsply import rotation
from conftest import read_exr, render_bit_identical_across_threads_and_passes, run, sharp_gaussian_render

W = H = 40
F = 45.0
BACKGROUND = (0.1, 0.2, 0.3)
TOL = 1e-4


def random_model(seed, n, degree, sub_pixel):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    k = (degree + 1) ** 2
    m = {"mean": rng.uniform(-0.7, 0.7, (n, 3)), "scale": rng.uniform(0.08, 0.35, (n, 2)),
         "rot": q / np.linalg.norm(q, axis=1)[:, None],
         # below ~0.35 the official tiles' 3-sigma cut never matters (alpha < 1/255 beyond it)
         "opacity": rng.uniform(0.15, 0.34, n), "sh": rng.normal(0, 0.4, (n, k, 3)), "degree": degree}
    m["scale"][:sub_pixel] = rng.uniform(1e-4, 3e-3, (sub_pixel, 2))
    return m


CAMERAS = [(0.0, 0.0), (0.35, -0.25)]  # straight on; yawed and pitched


def render_pair(tmp_path, model, yaw_pitch, order="center-depth"):
    ply = tmp_path / "model.ply"
    gsply.write(ply, model)
    R = rotation(*yaw_pitch)
    C = -4.0 * R[:, 2]
    order_attr = "" if order == "center-depth" else f' order="{order}"'
    img = sharp_gaussian_render(tmp_path, gsply.camera_xml(R, C, F, W, H), ply, order_attr)
    return img, gsply.read(ply), R, C


def point_major(model):
    """The SH rest coefficients as a reader that took them point-major would see them."""
    m = dict(model)
    sh = model["sh"].copy()
    n, k = len(sh), sh.shape[1]
    rest = sh[:, 1:, :].transpose(0, 2, 1).reshape(n, 3 * (k - 1))  # as stored
    sh[:, 1:, :] = rest.reshape(n, k - 1, 3)
    m["sh"] = sh
    return m



@pytest.mark.parametrize("degree", [0, 3])
@pytest.mark.parametrize("yaw_pitch", CAMERAS)
def test_a_sharp_point_sampled_render_is_the_official_forward_pass(tmp_path, degree, yaw_pitch):
    img, model, R, C = render_pair(tmp_path, random_model(11 + degree, 60, degree, sub_pixel=10), yaw_pitch)
    expect, final_t = ref.render(model, R, C, F, F, W, H, BACKGROUND)
    assert np.abs(img[..., :3] - expect).max() < TOL
    assert np.abs(img[..., 3] - (1 - final_t)).max() < TOL  # coverage is 1 - the final transmittance
    assert (final_t < 0.5).sum() > 50  # the splats overlap: most of the image is composited


def test_the_scene_exercises_the_filter_the_order_and_the_sh_layout(tmp_path, monkeypatch):
    """The planted errors the comparison above must catch change this scene by far more than 1e-4."""
    model = gsply.read(_write(tmp_path, random_model(14, 60, 3, sub_pixel=10)))
    R = rotation(*CAMERAS[1])
    C = -4.0 * R[:, 2]
    right, _ = ref.render(model, R, C, F, F, W, H, BACKGROUND)
    wrong_sh, _ = ref.render(point_major(model), R, C, F, F, W, H, BACKGROUND)
    assert np.abs(wrong_sh - right).max() > 100 * TOL
    by_hit = _hit_depth_reference(model, R, C)
    assert np.abs(by_hit - right).max() > 100 * TOL
    monkeypatch.setattr(ref, "projected_centre", lambda T: np.array([1e9, 1e9]))  # rho2d never wins
    unfiltered, _ = ref.render(model, R, C, F, F, W, H, BACKGROUND)
    assert np.abs(unfiltered - right).max() > 100 * TOL


def test_hit_depth_order_is_the_reference_sorted_by_each_hit(tmp_path):
    img, model, R, C = render_pair(tmp_path, random_model(14, 60, 0, sub_pixel=0), CAMERAS[1], order="hit-depth")
    assert np.abs(img[..., :3] - _hit_depth_reference(model, R, C)).max() < TOL
    center, _ = ref.render(model, R, C, F, F, W, H, BACKGROUND)
    assert np.abs(img[..., :3] - center).max() > 100 * TOL  # and not the centre-depth image


def _write(tmp_path, model):
    path = tmp_path / "m.ply"
    gsply.write(path, model)
    return path


def _hit_depth_reference(model, R, C):
    """The reference with each pixel's hits sorted by their own depth instead of the centre's: the
    reference's per-Gaussian quantities, composited here per pixel in that order."""
    R, C = np.asarray(R, float), np.asarray(C, float)
    items = []
    for i in range(len(model["opacity"])):
        T, depth = ref.splat_transform(model["mean"][i], model["scale"][i], model["rot"][i], R, C, F, F, W, H)
        if depth <= 0.2:
            continue
        d = model["mean"][i] - C
        items.append((i, T, ref.projected_centre(T), ref.sh_to_rgb(model["sh"][i], model["degree"],
                                                                    d / np.linalg.norm(d))))
    image = np.zeros((H, W, 3))
    for j in range(H):
        for i in range(W):
            px, py = i + 0.5, j + 0.5
            hits = []
            for idx, T, centre, rgb in items:
                k, l = -T[0] + px * T[2], -T[1] + py * T[2]
                det = k[0] * l[1] - k[1] * l[0]
                if det == 0:
                    continue
                u = (l[2] * k[1] - k[2] * l[1]) / det
                v = -(l[2] * k[0] - k[2] * l[0]) / det
                rho3d, rho2d = u * u + v * v, 2.0 * ((centre[0] - px) ** 2 + (centre[1] - py) ** 2)
                depth = u * T[2][0] + v * T[2][1] + T[2][2] if rho3d <= rho2d else T[2][2]
                alpha = min(0.99, model["opacity"][idx] * np.exp(-0.5 * min(rho3d, rho2d)))
                plane = u * T[2][0] + v * T[2][1] + T[2][2]
                if alpha >= 1 / 255 and plane >= 0.2:
                    hits.append((depth, idx, alpha, rgb))
            colour, t = np.zeros(3), 1.0
            for _, _, alpha, rgb in sorted(hits, key=lambda h: (h[0], h[1])):
                if t * (1 - alpha) < 1e-4:
                    break
                colour += rgb * alpha * t
                t *= 1 - alpha
            image[j, i] = colour + t * np.asarray(BACKGROUND)
    return image


def _one_facing(tmp_path, opacity, colour):
    """One surfel facing the camera, centred on the middle pixel's centre at depth 4 (rho = 0 there)."""
    m = {"mean": np.array([[0.5 * 4 / F, 0.5 * 4 / F, 0.0]]), "scale": np.array([[0.3, 0.3]]),
         "rot": np.array([[1.0, 0, 0, 0]]), "opacity": np.array([opacity]),
         "sh": ((np.asarray(colour) - 0.5) / ref.SH_C0).reshape(1, 1, 3), "degree": 0}
    return _write(tmp_path, m)


@pytest.mark.parametrize("sphere_depth", [6.0, 2.0])
def test_a_gaussian_composites_over_the_surface_behind_it_and_hides_behind_one_in_front(tmp_path, sphere_depth):
    """Mixed scenes: the epsilon-blended surfaces are opaque; a Gaussian in front composites over them
    (alpha c + (1 - alpha) surface), one behind is hidden. An unlit analytic sphere shows its colour."""
    ply = _one_facing(tmp_path, 0.7, (0.9, 0.1, 0.1))
    sphere = (f'<object name="s" position="0 0 {sphere_depth}"><sphere radius="0.5" color="0.1 0.3 0.9"/>'
              '<material shading="unlit"/></object>')
    scene = tmp_path / "mixed.xml"
    camera = gsply.camera_xml(np.eye(3), np.zeros(3), F, W, H)
    scene.write_text(f'<scene>{camera}<background color="0 0 0"/>'
                     f'<object name="g" position="0 0 4"><gaussianModel file="{ply}"/></object>{sphere}</scene>')
    out = tmp_path / "mixed.exr"
    proc = run([scene, "--pixel-filter", "point", "--time", 0, "--spp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    px = read_exr(out)[0][H // 2, W // 2]
    blue = np.array([0.1, 0.3, 0.9])
    expect = 0.7 * np.array([0.9, 0.1, 0.1]) + 0.3 * blue if sphere_depth > 4 else blue
    assert np.abs(px[:3] - expect).max() < 1e-5 and px[3] == 1.0


def test_what_cannot_be_combined_is_refused_with_its_reason(tmp_path):
    ply = _one_facing(tmp_path, 0.7, (0.9, 0.1, 0.1))
    scene = tmp_path / "g.xml"
    scene.write_text(f'<scene>{gsply.camera_xml(np.eye(3), np.zeros(3), F, W, H)}'
                     f'<object name="g" position="0 0 4"><gaussianModel file="{ply}"/></object></scene>')
    out = tmp_path / "x.exr"
    cases = [(["--time-integration", "exact"], 1, "does not integrate Gaussian-splat objects"),
             (["--time", 0.5, "--shutter", "0,1"], 2, "--time renders one instant"),
             (["--blur-space", "linear", "--time-integration", "exact"], 2, "exact time cannot do"),
             (["--blur-space", "clamped", "--time-integration", "exact"], 2, "clamps each instant's colour"),
             (["--pixel-filter", "gauss"], 2, "expected box or point"),
             (["--blur-space", "srgb"], 2, "expected model, linear or clamped")]
    for args, status, why in cases:
        proc = run([scene, "--spp", 1, "-o", out, "--quiet", *args])
        assert proc.returncode == status and why in proc.stderr, (args, proc.stderr)
        assert not out.exists()


def test_a_moving_gaussian_render_is_bit_identical_for_any_threads_and_passes(tmp_path):
    """The hits are sorted by (key, object, Gaussian) and windows are per ray: nothing depends on
    thread count or pass split (the guarantee every render has)."""
    ply = _write(tmp_path, random_model(5, 40, 3, sub_pixel=5))
    scene = tmp_path / "moving.xml"
    scene.write_text(f'<scene>{gsply.camera_xml(rotation(0.2, 0.1), [0, 0, -4], F, W, H)}'
                     f'<object name="g"><gaussianModel file="{ply}"/>'
                     f'<animation><rotation axis="0 1 0" degrees_per_unit_time="40"/></animation></object></scene>')
    common = [scene, "--spp", 4, "--tspp", 4, "--batches", 4, "--quiet"]
    img = render_bit_identical_across_threads_and_passes(tmp_path, common, (1, 2, 3))
    assert img[..., 3].max() > 0.5


def random_3d_model(seed, n, degree):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    return {"mean": rng.uniform(-0.7, 0.7, (n, 3)), "scale": rng.uniform(0.04, 0.3, (n, 3)),
            "rot": q / np.linalg.norm(q, axis=1)[:, None], "opacity": rng.uniform(0.2, 0.95, n),
            "sh": rng.normal(0, 0.4, (n, (degree + 1) ** 2, 3)), "degree": degree}


@pytest.mark.parametrize("degree", [0, 3])
def test_a_3dgs_render_under_3dgrt_semantics_is_3dgrt_ray_tracing(tmp_path, degree):
    """3D models under semantics="3dgrt" follow 3DGRT (tests/gs3d_grt_reference.py, written from nv-tlabs/3dgrut's rules):
    per pixel within 1e-4, and not the 2DGS rules on the same model's first two scales."""
    import gs3d_grt_reference as grt
    ply = _write(tmp_path, random_3d_model(21 + degree, 50, degree))
    R, C = rotation(0.3, -0.2), None
    C = -4.0 * R[:, 2]
    img = sharp_gaussian_render(tmp_path, gsply.camera_xml(R, C, F, W, H), ply, ' semantics="3dgrt"', "g3")
    model = gsply.read(ply)
    expect, final_t = grt.render(model, R, C, F, F, W, H, BACKGROUND)
    assert np.abs(img[..., :3] - expect).max() < TOL
    assert np.abs(img[..., 3] - (1 - final_t)).max() < TOL
    assert (final_t < 0.5).sum() > 50


def test_3dgrt_composites_the_hit_that_crosses_its_minimum_transmittance(tmp_path):
    """Three opaque 3D Gaussians on the axis: 3DGRT composites while T > 0.001, so the second (T = 0.01
    before it) is composited and the third not; 2DGS's rule (stop before T < 1e-4) would stop earlier."""
    import gs3d_grt_reference as grt
    m = {"mean": np.array([[0.5 * z / F, 0.5 * z / F, z - 4.0] for z in (3.0, 4.0, 5.0)]),
         "scale": np.full((3, 3), 0.2), "rot": np.tile([1.0, 0, 0, 0], (3, 1)), "opacity": np.full(3, 0.995),
         "sh": ((np.eye(3) - 0.5) / ref.SH_C0)[:, None, :], "degree": 0}
    ply = _write(tmp_path, m)
    img = sharp_gaussian_render(tmp_path, gsply.camera_xml(np.eye(3), [0, 0, -4.0], F, W, H), ply,
                                ' kind="3dgs" semantics="3dgrt"', "axis", background="1 1 1")
    px = img[H // 2, W // 2, :3]
    expect, T = grt.trace(gsply.read(ply), *grt.pixel_ray(np.eye(3), [0, 0, -4.0], F, F, W, H, W / 2 + 0.5,
                                                          H / 2 + 0.5), (1, 1, 1))
    assert 1e-5 < T < 1e-3 and expect[1] > 0.009  # green composited after T fell to about 0.005
    assert np.abs(px - expect).max() < TOL


def test_an_edge_on_surfel_seen_through_the_filter_is_skipped_where_its_plane_is_behind_the_camera(tmp_path):
    """forward.cu (e0ed020) skips a hit whose plane intersection is nearer than 0.2, also where the
    low-pass filter gives it its alpha: a sub-pixel surfel whose plane nearly holds the view ray shows
    on one side of its centre only (the plane hit is behind the camera on the other)."""
    a = np.arctan(0.01)  # plane x = 0.01 (z - 4): normal turned from x towards -z
    m = {"mean": np.array([[0.5 * 4 / F, 0.5 * 4 / F, 4.0]]), "scale": np.array([[2e-3, 2e-3]]),
         "rot": np.array([[np.cos((np.pi / 2 - a) / 2), 0, -np.sin((np.pi / 2 - a) / 2), 0]]),
         "opacity": np.array([0.9]), "sh": np.full((1, 1, 3), 1.0), "degree": 0}
    ply = _write(tmp_path, m)
    img = sharp_gaussian_render(tmp_path, gsply.camera_xml(np.eye(3), np.zeros(3), F, W, H), ply, "", "edge",
                                background="0 0 0")
    expect, T = ref.render(gsply.read(ply), np.eye(3), np.zeros(3), F, F, W, H, (0, 0, 0))
    assert np.abs(img[..., :3] - expect).max() < TOL
    row = T[H // 2, W // 2 - 2: W // 2 + 3]  # the filter reaches 2 pixels either side of the centre's pixel
    assert row.min() < 0.5 and row.max() == 1.0  # seen on one side, skipped on the other


def _render_2d(tmp_path, model, R, C, f, w, h, attrs=""):
    """refrender's sharp point-sampled image of a 2D model under a square-pixel camera of focal f."""
    ply = _write(tmp_path, model)
    return sharp_gaussian_render(tmp_path, gsply.camera_xml(R, C, f, w, h), ply, ' kind="2dgs"' + attrs, "s2"), \
        gsply.read(ply)


def _tilted_elongated(seed, n=14):
    """Splats turned 50 to 80 degrees from the view and 4 to 8 times longer than wide."""
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=(n, 3)) * [1, 1, 0.2]
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    half = rng.uniform(np.radians(50), np.radians(80), n) / 2
    q = np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * axis], axis=1)
    wide = rng.uniform(0.03, 0.08, n)
    return {"mean": rng.uniform(-0.6, 0.6, (n, 3)), "scale": np.stack([wide * rng.uniform(4, 8, n), wide], axis=1),
            "rot": q, "opacity": rng.uniform(0.3, 0.9, n), "sh": rng.normal(0, 0.4, (n, 1, 3)), "degree": 0}


# each 2D semantics, its filter centre and its near rule in the reference (up to 7bdbd51 the near
# skip took the centre's depth where the filter wins: near_depth="centre-if-filter")
SEMANTICS_2D = [("2dgs", "cutoff", "hit"), ("2dgs-center-near", "cutoff", "centre-if-filter"),
                ("2dgs-unit-circle", "unit-circle", "centre-if-filter")]


@pytest.mark.parametrize("semantics,centre,near", SEMANTICS_2D, ids=[s[0] for s in SEMANTICS_2D])
def test_the_filter_centre_is_e0ed020s_and_the_unit_circle_variant_the_older_one(tmp_path, semantics, centre, near):
    """e0ed020 (the commit 2DGS pins) centres the low-pass filter on the image of the 3-sigma circle's
    centre (compute_aabb, since 909dd85); before, on the unit circle's. On tilted, elongated splats the
    two differ by far more than the tolerance, and each semantics is its reference."""
    R = rotation(0.3, -0.2)
    C = -4.0 * R[:, 2]
    img, model = _render_2d(tmp_path, _tilted_elongated(5), R, C, F, W, H, f' semantics="{semantics}"')
    expect, final_t = ref.render(model, R, C, F, F, W, H, BACKGROUND, centre=centre, near_depth=near)
    assert np.abs(img[..., :3] - expect).max() < TOL
    other, _ = ref.render(model, R, C, F, F, W, H, BACKGROUND,
                          centre="unit-circle" if centre == "cutoff" else "cutoff")
    assert np.abs(other - expect).max() > 100 * TOL


@pytest.mark.parametrize("semantics,centre,near", SEMANTICS_2D, ids=[s[0] for s in SEMANTICS_2D])
def test_the_2dgs_tile_rule_draws_what_the_rasterizer_draws(tmp_path, semantics, centre, near):
    """tileRule="on": a splat only in the 16x16 tiles of its compute_aabb rectangle (each version's
    radius); opaque splats' tails beyond it are cut, as in the official image."""
    R, C = np.eye(3), np.array([0.0, 0.0, -4.0])
    model = random_model(17, 30, 0, sub_pixel=0)
    model["opacity"] = np.full(30, 0.98)
    img, read = _render_2d(tmp_path, model, R, C, 60.0, 64, 48, f' tileRule="on" semantics="{semantics}"')
    expect, _ = ref.render(read, R, C, 60.0, 60.0, 64, 48, BACKGROUND, tile_rule=True, centre=centre,
                           near_depth=near)
    assert np.abs(img[..., :3] - expect).max() < TOL
    untiled, _ = ref.render(read, R, C, 60.0, 60.0, 64, 48, BACKGROUND, centre=centre, near_depth=near)
    assert np.abs(untiled - expect).max() > 10 * TOL


@pytest.mark.parametrize("fov", [60, 90, 136])
def test_no_2dgs_splat_is_missed_by_wide_lenses_far_off_axis(tmp_path, fov):
    """Opaque splats up to 60 degrees off the axis of a wide lens: every one whose alpha reaches 1/255
    at a pixel is composited there (the reference evaluates every splat at every pixel). A pre-cull
    that bounds a splat's image by its on-axis size (f |delta| / (z - |delta|)) misses their edges."""
    w, h = 48, 32
    f = w / (2 * np.tan(np.radians(fov) / 2))
    rng = np.random.default_rng(fov)
    n = 24
    ang = np.radians(rng.uniform(-min(60, 0.48 * fov), min(60, 0.48 * fov), n))
    z = rng.uniform(1.0, 3.0, n)
    mean = np.stack([np.tan(ang) * z, rng.uniform(-0.3, 0.3, n) * z, z], axis=1)
    q = rng.normal(size=(n, 4))
    model = {"mean": mean, "scale": rng.uniform(0.02, 0.12, (n, 2)) * z[:, None],
             "rot": q / np.linalg.norm(q, axis=1)[:, None], "opacity": np.full(n, 0.99),
             "sh": rng.normal(0, 0.4, (n, 1, 3)), "degree": 0}
    img, read = _render_2d(tmp_path, model, np.eye(3), np.zeros(3), f, w, h)
    expect, final_t = ref.render(read, np.eye(3), np.zeros(3), f, f, w, h, BACKGROUND)
    err = np.abs(img[..., :3] - expect)
    assert err.max() < TOL, (err.max(), np.unravel_index(err.argmax(), err.shape))
    assert (final_t < 0.5).sum() > 20


def test_with_the_tile_rule_a_splat_reaching_behind_the_camera_plane_is_drawn_in_its_hyperbola_tiles(tmp_path):
    """A splat whose radius-3 circle reaches behind the camera's plane: its image is a hyperbola,
    and e0ed020's compute_aabb goes on with it (only d == 0 culls), so the official image draws
    the splat's ray hits in the tiles about the hyperbola's centre, filtered about that centre
    (GAUSSIANS.md). Its pixels, one by one, are those gs2d_reference.drawn_pixels finds from
    forward.cu; refrender dropped the splat (0 pixels)."""
    R, C, f, w, h = np.eye(3), np.zeros(3), 20.0, 48, 48
    th = np.radians(30)  # v = 4 turned 30 deg at depth 5: 3 * 4 sin 30 = 6 > 5 reaches z < 0
    model = {"mean": np.array([[0.0, 0.0, 5.0]]), "scale": np.array([[0.5, 4.0]]),
             "rot": np.array([[np.cos(th / 2), np.sin(th / 2), 0.0, 0.0]]), "opacity": np.array([0.8]),
             "sh": ((np.array([0.9, 0.2, 0.1]) - 0.5) / ref.SH_C0).reshape(1, 1, 3), "degree": 0}
    img, read = _render_2d(tmp_path, model, R, C, f, w, h, ' tileRule="on"')
    T, _ = ref.splat_transform(read["mean"][0], read["scale"][0], read["rot"][0], R, C, f, f, w, h)
    assert (T @ np.diag([9.0, 9.0, -1.0]) @ T.T)[2, 2] > 0  # a hyperbola
    drawn = ref.drawn_pixels(read, 0, R, C, f, f, w, h)
    assert drawn.sum() > 40 and not drawn[:16].any()  # the hyperbola's tiles start at pixel row 16
    assert np.array_equal(img[..., 3] > 0, drawn)
    expect, _ = ref.render(read, R, C, f, f, w, h, BACKGROUND, tile_rule=True)
    assert np.abs(img[..., :3] - expect).max() < TOL
