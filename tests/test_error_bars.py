"""The standard errors of --batches hold, for every sampler, on pixels whose value steps in time
and on smooth ones: over many pixels the share whose error is beyond k standard errors is the
share a t distribution with B - 1 degrees of freedom puts there (B = 4 batches, k = 2 and 3).

Pixels are independent (each has its own counter-based random streams, src/render/sampler.h), so
one render of many pixels is many trials. Shares must lie within [0.6 p - 3 s, 1.4 p + 3 s], p the
t distribution's two-sided tail, s the binomial standard deviation of a share of that many pixels:
a standard error 2x too large puts 0.03 beyond 2 (3x too large, batches that were blocks of one
Sobol' sequence, almost none), one 0.7x too small 0.26, and one that is 0 on a step (every batch
on the same strata: batches agreeing exactly) puts the pixel beyond every k.

- Steps: a white unlit disc of radius 0.5 moves from x = -1.2 to x = 1.2 over the shutter on
  the plane z = 0, seen from z = 5 with --pixel-filter point; a pixel's value is the fraction of
  the shutter during which the disc covers the point its centre ray meets (worked out here from
  the pinhole camera, README's conventions: vertical fov, square pixels), a value that steps up
  and down at two instants.
- Smooth: a large Phong-shaded splat tilting under a point light, box filter: no closed form, so
  the test compares two renders of other seeds, (m1 - m2) / sqrt(se1^2 + se2^2), whose
  distribution is a t with between B - 1 and 2 B - 2 degrees of freedom (Welch); the bounds take
  the lower tail of the one and the upper of the other.
"""
import math

import numpy as np
import pytest

from conftest import imagecompare, run

B = 4
W, H, FOV = 96, 32, 40.0
RADIUS, X0, X1 = 0.5, -1.2, 1.2

STEP = f"""<scene><camera position="0 0 5" lookat="0 0 0" up="0 1 0" fov="{FOV}" width="{W}" height="{H}"/>
<shutter open="0" close="1" weight="box"/><background color="0 0 0"/><render time_factor="4"/>
<object name="disc" position="{X0} 0 0"><pointModel>
<splat center="0 0 0" normal="0 0 1" radius="{RADIUS}" color="1 1 1"/></pointModel>
<material shading="unlit"/><animation><linear velocity="{X1 - X0} 0 0"/></animation></object></scene>"""

SMOOTH = """<scene><camera position="0 0 5" lookat="0 0 0" up="0 1 0" fov="20" width="48" height="32"/>
<shutter open="0" close="1" weight="box"/><background color="0 0 0"/><ambient color="0.1 0.1 0.1"/>
<light type="point" position="1 2 3" color="0.9 0.9 0.9"/><render time_factor="4"/>
<object name="tilt"><pointModel><splat center="0 0 0" normal="0 0 1" radius="5" color="0.8 0.7 0.6"/></pointModel>
<material shading="phong" diffuse="1" specular="0.5" shininess="8"/>
<animation><rotation axis="1 0.3 0" center="0 0 0" degrees_per_unit_time="40"/></animation></object></scene>"""

SAMPLERS = ["sobol", "jittered3d", "thesis"]


def t_tail(k, nu):
    """P(|T| > k) for Student's t with nu degrees of freedom (its density integrated numerically
    from k to 60, the rest below 1e-6 for nu >= 3)."""
    c = math.gamma((nu + 1) / 2) / (math.sqrt(nu * math.pi) * math.gamma(nu / 2))
    x = np.linspace(k, 60.0, 200001)
    f = c * (1 + x * x / nu) ** (-(nu + 1) / 2)
    return 2 * float(np.sum((f[1:] + f[:-1]) / 2 * np.diff(x)))


def step_truth():
    """The analytic pixel values of STEP: the pixel centre's ray from (0, 0, 5) meets z = 0 at
    5 (sx, sy) (sx, sy: the pinhole's tangents at the centre); the disc's centre is at
    X0 + (X1 - X0) t, so it covers the point while that centre lies within sqrt(R^2 - Y^2) of X."""
    tan = math.tan(math.radians(FOV) / 2)
    px = np.arange(W) + 0.5
    py = np.arange(H) + 0.5
    X = 5 * (2 * px / W - 1) * tan * W / H
    Y = 5 * (1 - 2 * py / H) * tan
    half = np.sqrt(np.maximum(RADIUS ** 2 - Y ** 2, 0))[:, None]
    lo = np.maximum(X[None, :] - half, X0)
    hi = np.minimum(X[None, :] + half, X1)
    return np.where(half > 0, np.maximum(hi - lo, 0) / (X1 - X0), 0.0)


def render(tmp_path, text, sampler, seed, *extra):
    scene = tmp_path / "s.xml"
    scene.write_text(text)
    out = tmp_path / f"{sampler}-{seed}.exr"
    proc = run([scene, "--sampler", sampler, "--seed", seed, "--batches", B, "-o", out, "--quiet", *extra])
    assert proc.returncode == 0, proc.stderr
    channels, _, _ = imagecompare.read_channels(out, unassociated_alpha=False)
    return channels["R"].astype(float), channels["stderr.R"].astype(float)


def ratios(err, se):
    """|error| / standard error; a standard error of 0 with an error is infinitely far off."""
    return np.where(se > 0, np.abs(err) / np.where(se > 0, se, 1), np.where(np.abs(err) > 1e-7, np.inf, 0))


def assert_calibrated(r, p_low, p_high, what):
    n = r.size
    for k in (2, 3):
        share = float(np.mean(r > k))
        lo, hi = p_low(k), p_high(k)
        s_lo, s_hi = math.sqrt(lo * (1 - lo) / n), math.sqrt(hi * (1 - hi) / n)
        assert 0.6 * lo - 3 * s_lo <= share <= 1.4 * hi + 3 * s_hi, (
            f"{what}: {share:.4f} of {n} pixels beyond {k} standard errors; "
            f"a t distribution puts {lo:.4f}-{hi:.4f} there")


def test_the_analytic_step_values_are_what_the_disc_covers():
    truth = step_truth()
    assert truth.max() == pytest.approx(2 * math.sqrt(RADIUS ** 2 - (5 * math.tan(math.radians(20)) / H) ** 2)
                                        / (X1 - X0), rel=1e-12)
    assert ((truth > 0.01) & (truth < 0.99)).sum() >= 200


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_error_bars_hold_where_pixels_step_in_time(tmp_path, sampler):
    truth = step_truth()
    stepping = (truth > 0.01) & (truth < 0.99)
    r = []
    for seed in (1, 2, 3, 4):
        value, se = render(tmp_path, STEP, sampler, seed, "--spp", 1, "--tspp", 64, "--pixel-filter", "point")
        r.append(ratios(value - truth, se)[stepping])
    assert_calibrated(np.concatenate(r), lambda k: t_tail(k, B - 1), lambda k: t_tail(k, B - 1), sampler)


@pytest.mark.parametrize("sampler", SAMPLERS)
def test_error_bars_hold_on_smooth_pixels(tmp_path, sampler):
    r = []
    for seed in (1, 3):
        m1, se1 = render(tmp_path, SMOOTH, sampler, seed, "--spp", 4, "--tspp", 16)
        m2, se2 = render(tmp_path, SMOOTH, sampler, seed + 1, "--spp", 4, "--tspp", 16)
        r.append(ratios(m1 - m2, np.hypot(se1, se2)).ravel())
    assert_calibrated(np.concatenate(r), lambda k: t_tail(k, 2 * B - 2), lambda k: t_tail(k, B - 1), sampler)
