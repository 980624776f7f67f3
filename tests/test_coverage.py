"""End-to-end checks of the core renderer against closed-form answers.
Tolerances are stated in standard errors."""
import numpy as np

from conftest import focal_pixels

SCENE = """<scene>
 <camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="{fov}" width="{w}" height="{h}"/>
 <shutter open="0" close="1" {weight}/>
 <render epsilon="0.01"/>
 <object>{geometry}<material shading="unlit"/>{animation}</object>
</scene>"""


def scene(geometry, w=64, h=64, fov=40, weight="", animation=""):
    return SCENE.format(geometry=geometry, w=w, h=h, fov=fov, weight=weight, animation=animation)


def pixel_distance_to(center_x, center_y, w, h):
    y, x = np.mgrid[0:h, 0:w] + 0.5
    return np.hypot(x - center_x, y - center_y)


def check_disk_coverage(alpha, radius_px, spp):
    """Projected disk of radius r pixels, centered in the image: total
    coverage is pi r^2; pixels entirely inside are exactly 1 and entirely
    outside exactly 0. A boundary pixel's jittered estimate has variance at
    most 1/(4 spp), so the total's standard error is below
    sqrt(n_boundary / (4 spp)); allow 5 of them."""
    h, w = alpha.shape
    dist = pixel_distance_to(w / 2, h / 2, w, h)
    inside, outside = dist < radius_px - 0.75, dist > radius_px + 0.75
    assert np.all(alpha[inside] == 1.0)
    assert np.all(alpha[outside] == 0.0)
    boundary = np.count_nonzero(~inside & ~outside)
    se = np.sqrt(boundary / (4 * spp))
    assert abs(alpha.sum() - np.pi * radius_px ** 2) < 5 * se, (alpha.sum(), np.pi * radius_px ** 2, se)


def test_static_sphere_coverage_matches_projected_area(render):
    # A sphere of radius R at distance D subtends a cone of half-angle
    # asin(R/D); centered on the axis its image is a disk of radius
    # tan(asin(R/D)) on the plane at depth 1.
    R, D, fov, h = 2.0, 10.0, 40.0, 64
    img = render(scene(f'<sphere center="0 0 -{D}" radius="{R}"/>', fov=fov, h=h), "--spp", 16, "--tspp", 1)
    radius_px = np.tan(np.arcsin(R / D)) * focal_pixels(h, fov)
    check_disk_coverage(img[:, :, 3], radius_px, 16)


def test_static_unlit_splat_coverage_and_color(render):
    # A splat facing the camera at depth D projects to a disk of radius R/D.
    R, D, fov, h = 1.0, 5.0, 40.0, 64
    geometry = f'<pointModel><splat center="0 0 -{D}" normal="0 0 1" radius="{R}" color="1 0.5 0.25"/></pointModel>'
    img = render(scene(geometry, fov=fov, h=h), "--spp", 16, "--tspp", 1)
    check_disk_coverage(img[:, :, 3], R / D * focal_pixels(h, fov), 16)
    # unlit over a black background: color = splat color x coverage
    np.testing.assert_allclose(img[:, :, 1], 0.5 * img[:, :, 3], atol=1e-6)


def chord_integral(y0, y1, rho):
    """Integral over y in [y0, y1] of the chord length 2 sqrt(rho^2 - y^2)."""
    def F(y):
        y = np.clip(y, -rho, rho)
        return y * np.sqrt(rho ** 2 - y ** 2) + rho ** 2 * np.arcsin(y / rho)
    return F(y1) - F(y0)


def test_linearly_moving_disk_matches_chord_over_speed(render):
    # A disk parallel to the image plane stays a circle of constant radius
    # rho (pixels) and moves at constant image speed s (pixels per shutter).
    # Far from the ends of its path a point at height y from the path's axis
    # is covered for a fraction 2 sqrt(rho^2 - y^2) / s of the shutter, so a
    # pixel row j expects (1/s) * integral over the row of that chord.
    w, h, fov, D = 160, 40, 30.0, 10.0
    f = focal_pixels(h, fov) / D                 # pixels per world unit at depth D
    rho_px, path_px = 12.0, 64.0
    R, v = rho_px / f, path_px / f
    geometry = (f'<pointModel><splat center="{-v / 2} 0 -{D}" normal="0 0 1" radius="{R}" '
                f'color="1 1 1"/></pointModel>')
    img = render(scene(geometry, w=w, h=h, fov=fov, animation=f'<animation><linear velocity="{v} 0 0"/></animation>'),
                 "--spp", 4, "--tspp", 16, "--seed", 7)
    alpha = img[:, :, 3]
    # columns whose whole pixel lies where every chord fits inside the path
    x_lo, x_hi = w / 2 - path_px / 2 + rho_px, w / 2 + path_px / 2 - rho_px
    cols = np.arange(int(np.ceil(x_lo)), int(np.floor(x_hi)))
    assert len(cols) >= 30
    for j in range(h):
        y0, y1 = j - h / 2, j + 1 - h / 2
        expected = chord_integral(y0, y1, rho_px) / path_px
        row = alpha[j, cols]
        se = row.std(ddof=1) / np.sqrt(len(row))
        assert abs(row.mean() - expected) <= 5 * se + 1e-4, (j, row.mean(), expected, se)


def test_temporal_weight_of_disk_present_in_first_half(render):
    # A huge disk whose edge sweeps the whole image in 0.4% of the shutter,
    # crossing the image center at t = 0.5: a pixel at world x (depth D) is
    # covered for t < 0.5 - x/v. Its expected value is W(0.5 - x/v) / W(1),
    # W(s) = integral_0^s a(t) dt: box W(s) = s; linear with center 1:
    # W(s) = s^2/2; exp with center 1, rate 1: W(s) = e^(s-1) - e^-1.
    w = h = 96  # enough pixels that 5 SE is about 0.002 in coverage
    fov, D, R, v = 40.0, 10.0, 1000.0, 2000.0
    x0 = 0.5 * v - R
    weights = {
        'weight="box"': lambda s: s,
        'weight="linear"': lambda s: s * s / 2,
        'weight="exp" rate="1"': lambda s: np.exp(s - 1) - np.exp(-1),
    }
    y, x = np.mgrid[0:h, 0:w] + 0.5
    world_x = (x - w / 2) / focal_pixels(h, fov) * D
    for weight, W in weights.items():
        geometry = f'<pointModel><splat center="{x0} 0 -{D}" normal="0 0 1" radius="{R}"/></pointModel>'
        img = render(scene(geometry, w=w, h=h, fov=fov, weight=weight,
                           animation=f'<animation><linear velocity="{-v} 0 0"/></animation>'),
                     "--spp", 4, "--tspp", 32, "--seed", 3)
        alpha = img[:, :, 3].ravel()
        expected = (W(0.5 - world_x / v) / W(1.0)).ravel()
        diff = alpha - expected
        se = diff.std(ddof=1) / np.sqrt(diff.size)
        assert abs(diff.mean()) <= 5 * se, (weight, alpha.mean(), expected.mean(), se)


def test_weight_zero_on_98_percent_of_the_shutter_for_every_sampler(render):
    # The disk of the test above, its edge crossing the
    # image center at t = 0.5, seen through a(t) that is zero but on
    # [0.49, 0.51]. With 8 times a batch, most batches draw no time where
    # a(t) > 0: the ratio estimator sum a g / sum a gave those batches 0
    # (not even the background) and the image came out far too dark. The
    # expectation W(0.5 - x/v) / W(1) is integrated here with numpy on a
    # fine grid, from the table alone.
    w = h = 64
    fov, D, R, v = 40.0, 10.0, 1000.0, 200.0
    x0 = 0.5 * v - R
    table = [(0, 0), (0.49, 0), (0.495, 1), (0.505, 1), (0.51, 0), (1, 0)]
    grid = np.linspace(0, 1, 2_000_001)
    a = np.interp(grid, [p[0] for p in table], [p[1] for p in table])
    cum = np.concatenate([[0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(grid))])
    y, x = np.mgrid[0:h, 0:w] + 0.5
    world_x = (x - w / 2) / focal_pixels(h, fov) * D
    expected = (np.interp(0.5 - world_x / v, grid, cum) / cum[-1]).ravel()
    weight = 'weight="table" table="' + " ".join(f"{t} {wt}" for t, wt in table) + '"'
    geometry = f'<pointModel><splat center="{x0} 0 -{D}" normal="0 0 1" radius="{R}"/></pointModel>'
    for sampler in ["thesis", "jittered3d", "sobol"]:
        img = render(scene(geometry, w=w, h=h, fov=fov, weight=weight,
                           animation=f'<animation><linear velocity="{-v} 0 0"/></animation>'),
                     "--spp", 1, "--tspp", 8, "--batches", 4, "--sampler", sampler, "--seed", 5)
        diff = img[:, :, 3].ravel() - expected
        se = diff.std(ddof=1) / np.sqrt(diff.size)
        assert abs(diff.mean()) <= 5 * se, (sampler, img[:, :, 3].mean(), expected.mean(), se)
