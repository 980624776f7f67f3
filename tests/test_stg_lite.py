"""SpacetimeGaussians "lite" models (Li et al., CVPR 2024; oppo-us-research/SpacetimeGaussians at
427abfc5), whose Gaussians move, fade in and out over time and turn, rendered through the whole
command line (a PLY in the official layout, `<gaussianModel file=...>`, the EXR) against
tests/stg_reference.py, an independent numpy reference written from the official source (the
model at time t, then Inria's rasterizer, tests/gs3d_raster_reference.py, with precomputed
colours) without seeing refrender's C:
  (a) sharp instants (`--time T --pixel-filter point --spp 1`) at four times within 1e-4 of the
      reference (float against double arithmetic), colour and alpha;
  (b) the shutter integral (sampled time, --batches 16) against the midpoint rule over 256 of
      the reference's instants, unclamped (colours above 1 and below 0 stay as they are);
  (c) one flat Gaussian moving parallel to the image plane: the integral against the closed form
      (stg_reference.single_gaussian_integral, an erf expression) at pixels of its streak;
  (d) a clamped-instants mode, as the official test.py scores images (each instant clamped to
      [0, 1] before anything else): against the average of clamped instants.
The scenes hold Gaussians added by error-guided sampling (rot = 0: the identity), a non-unit rot
turning with omega, times far from a Gaussian's centre (where the temporal RBF's exponent, with
no 1/2, matters), quadratic and cubic motion, colours above 1 and below 0, a Gaussian whose
opacity is between 1/255 and 0.02 for part of the shutter (no temporal cut-off but the
rasterizer's own); test_stg_reference.py shows each planted error of the reference changes these
images by more than 1e-3.
Statistics, k stated: refrender's value within K standard errors (its B = 16 batches' own, a
t distribution with 15 degrees of freedom) plus the midpoint rule's error bound plus a 2e-5
floor for float arithmetic. K = 4 at a few named pixels (P(|t15| > 4) = 0.0012 each); every
pixel at K_ALL = 9 (P(|t15| > 9) < 2e-7, so about 1e-4 over a thousand values); and the median
over moving pixels of the excess in standard errors below 1.2 (its value for an unbiased
estimate is about 0.7): a bias of a standard error across the image fails it.
Time: the model's timestamp is the scene time (the official timestamps, (frame - start) / 50 for
a 50-frame segment, lie in [0, 1)): `--time T` and `<shutter open close>` are model times here."""
import numpy as np

import gsply
from gsply import rotation
import stg_reference as stg
from conftest import read_exr, read_full, run

MODEL_ATTRS = ""             # extra <gaussianModel> attributes, if refrender needs any to read STG-lite
CLAMP_OPTION = "--blur-space=clamped"  # the clamped-instants mode (one argument: --blur-space clamped)
TOL = 1e-4
FLOOR = 2e-5
K, K_ALL, MEDIAN_MAX = 4.0, 9.0, 1.2
BATCHES = 16
QUAD = 256

SHARP_TIMES = (0.0, 0.31, 0.62, 0.97)
SHUTTER = (0.2, 0.7)


def gaussian(xyz, colour, opacity, scale, rot=(1, 0, 0, 0), omega=(0, 0, 0, 0), motion=(0,) * 9, centre=0.5,
             tau=0.5):
    """One Gaussian's raw (stored) parameters from activated values: opacity in (0, 1), scale > 0,
    tau = exp(trbf_scale) > 0; rot, omega, motion, f_dc stored as given."""
    return {"xyz": xyz, "trbf_center": centre, "trbf_scale": np.log(tau), "motion": motion, "f_dc": colour,
            "opacity": np.log(opacity / (1 - opacity)), "scale": np.log(scale), "rot": rot, "omega": omega}


def stack(gaussians):
    return {k: np.array([np.asarray(g[k], np.float64) for g in gaussians]) for k in stg.FIELDS}


def mixed_model():
    """Ten Gaussians about the origin (the camera looks at it from 3.5 away): see the module
    docstring for what each is there for."""
    gs = [
        # added by error-guided sampling: rot = 0, omega = 0 (the identity); elongated along x
        gaussian((-0.9, -0.5, 0.3), (0.9, 0.3, 0.2), 0.75, (0.35, 0.08, 0.12), rot=(0, 0, 0, 0),
                 motion=(0.5, 0.2, 0, 0, 0, 0, 0, 0, 0), centre=0.5, tau=0.6),
        # non-unit rot (|rot| = 2.2) turning with omega: normalised once, after adding omega D
        gaussian((0.5, -0.4, -0.2), (0.2, 0.8, 0.4), 0.7, (0.4, 0.07, 0.15), rot=(1.8, 0.6, -0.9, 0.3),
                 omega=(0.4, -1.5, 2.0, 0.7), motion=(-0.3, 0.25, 0.1, 0, 0, 0, 0, 0, 0), centre=0.4, tau=0.8),
        # centred at t = 0 with a short RBF: |D| / tau up to 2.8 (the exponent has no 1/2);
        # colour above 1; quadratic and cubic motion
        gaussian((0.2, 0.6, 0.0), (1.8, 1.2, 0.3), 0.85, (0.25, 0.2, 0.2), rot=(0.9, 0.2, -0.1, 0.3),
                 motion=(0.4, -0.1, 0, 0.3, 0, 0, 0, 0.5, 0), centre=0.0, tau=0.35),
        # colour above 1 and below 0, turning, polynomial motion
        gaussian((-0.3, 0.2, 0.5), (1.6, -0.3, 0.7), 0.8, (0.2, 0.3, 0.1), rot=(0.9, 0.1, 0.3, -0.2),
                 omega=(0, 0.3, 0, -0.4), motion=(0.2, 0.1, 0, -0.6, 0.3, 0.05, 0.8, -0.5, 0), centre=0.6, tau=0.7),
        # large, bright, behind the others, fading fast: opacity between 1/255 and 0.02 over part of
        # the times (no temporal cut-off but alpha < 1/255)
        gaussian((0.9, 0.4, 0.9), (1.5, 1.5, 1.5), 0.9, (0.5, 0.45, 0.3), centre=0.3, tau=0.15),
    ]
    rng = np.random.default_rng(7)
    for k in range(5):
        q = rng.normal(size=4)
        depth = (-1.2, -1.0, -0.8, -0.6, 1.3)[k]  # apart from the others: no depth order changes
        gs.append(gaussian(np.append(rng.uniform(-1.0, 1.0, 2) * (1, 0.7), depth),
                           rng.uniform(-0.1, 1.4, 3), rng.uniform(0.4, 0.85), rng.uniform(0.08, 0.25, 3),
                           rot=q * rng.uniform(0.5, 2.0), omega=rng.normal(0, 0.8, 4),
                           motion=rng.normal(0, 0.4, 9) * np.tile((1, 1, 0.05), 3),  # little z motion
                           centre=rng.uniform(0, 1), tau=rng.uniform(0.2, 1.0)))
    return stack(gs)


def mixed_camera(W, H):
    """(R_c2w, C, f): a turned camera 3.5 from the origin, looking at it; f keeps the vertical
    field of view at 2 atan(24 / 52) whatever the resolution."""
    R = rotation(0.15, -0.1, 0.05)
    return R, -3.5 * R[:, 2], 52.0 * H / 48.0


def flat_model():
    """One flat Gaussian (third scale e^-40) facing the camera at depth 2.5, turned about the view
    axis, moving parallel to the image plane (6.4 pixels over the shutter at f = 20), fading with
    its RBF: the preconditions of stg_reference.single_gaussian_integral."""
    return stack([gaussian((-0.55, 0.05, 2.5), (1.4, 0.6, -0.1), 0.77, (0.06, 0.025, np.exp(-40.0)),
                           rot=(0.8, 0, 0, 0.5), motion=(1.6, -0.3, 0, 0, 0, 0, 0, 0, 0), centre=0.45, tau=0.4)])


FLAT_W, FLAT_H, FLAT_F = 24, 16, 20.0
FLAT_ROWS = (6, 10)                        # the streak's rows [6, 10): the crop window renders only these
# (column, row); the last one is where alpha barely passes 1/255: the cut halves its integral
FLAT_PIXELS = ((6, 8), (8, 8), (10, 7), (4, 9), (5, 6))


def scene_xml(ply, R, C, f, W, H, background=(0, 0, 0)):
    camera = gsply.camera_xml(R, C, f, W, H)
    bg = " ".join("%.17g" % v for v in background)
    return (f'<scene>{camera}<shutter open="{SHUTTER[0]}" close="{SHUTTER[1]}"/><background color="{bg}"/>'
            f'<object name="stg"><gaussianModel file="{ply}"{MODEL_ATTRS}/></object></scene>')


def write_scene(tmp_path, raw, R, C, f, W, H, background=(0, 0, 0), name="scene"):
    """The model in the official layout and its scene; returns (scene path, the model as read back)."""
    ply = tmp_path / f"{name}.ply"
    stg.write_stg_lite_ply(ply, raw)
    scene = tmp_path / f"{name}.xml"
    scene.write_text(scene_xml(ply, R, C, f, W, H, background))
    return scene, stg.read_stg_lite_ply(ply)


def render(scene, out, *args):
    proc = run([scene, "--pixel-filter", "point", "--spp", 1, "-o", out, "--quiet", *args])
    assert proc.returncode == 0, proc.stderr
    return out


def render_integral(tmp_path, scene, W, H, tspp, sampler="thesis", extra=(), rows=None, name="integral"):
    """(channels, header): the shutter integral with BATCHES batches' standard errors. rows:
    (row0, row1) renders only those rows (a crop window); a full-size array comes back, NaN
    elsewhere."""
    args = ["--tspp", tspp, "--batches", BATCHES, "--sampler", sampler, "--seed", 3, *extra]
    if rows:
        args += ["--crop-window", f"0,1,{rows[0] / H},{rows[1] / H}"]
    ch, header = read_full(render(scene, tmp_path / f"{name}.exr", *args))
    if rows:
        full = {}
        for key, v in ch.items():
            assert v.shape == (rows[1] - rows[0], W), v.shape
            full[key] = np.full((H, W), np.nan)
            full[key][rows[0]:rows[1]] = v
        ch = full
    return ch, header


def fine_average_with_bound(raw, R, C, f, W, H, clamp=False):
    """The midpoint rule at QUAD instants over the shutter and a bound on its error per pixel:
    twice its distance to the rule at QUAD/2 instants (the error falls as QUAD^-2 where the pixel
    is smooth in t, as QUAD^-1 across a jump), plus, for the jumps where a Gaussian's alpha crosses
    1/255 (at most |colour|/255 each, an error of at most that / (2 QUAD) per crossing), two crossings
    per Gaussian. The scenes keep every Gaussian's depth order over the shutter
    (test_stg_reference.py) and T away from 1e-4, so no other jumps."""
    fine, fine_a = stg.fine_average(raw, *SHUTTER, QUAD, R, C, f, f, W, H, clamp=clamp)
    coarse, coarse_a = stg.fine_average(raw, *SHUTTER, QUAD // 2, R, C, f, f, W, H, clamp=clamp)
    jumps = len(raw["xyz"]) * np.abs(raw["f_dc"]).max() / 255.0 / QUAD
    image = np.concatenate([fine, fine_a[..., None]], axis=-1)
    bound = 2.0 * np.abs(image - np.concatenate([coarse, coarse_a[..., None]], axis=-1)) + jumps
    return image, bound


def assert_within_errors(ch, expect, bound, named_pixels, where=None):
    """refrender's RGBA within K standard errors (+ bound + FLOOR) at named_pixels ((column, row)),
    within K_ALL everywhere (where: a mask of the pixels rendered), and the median excess over
    moving pixels below MEDIAN_MAX standard errors."""
    got = np.stack([ch[c] for c in "RGBA"], axis=-1)
    se = np.stack([ch[f"stderr.{c}"] for c in "RGBA"], axis=-1)
    where = np.ones(got.shape[:2], bool) if where is None else where
    excess = np.maximum(np.abs(got - expect) - bound - FLOOR, 0.0)
    for x, y in named_pixels:
        assert np.all(excess[y, x] <= K * se[y, x]), ((x, y), got[y, x], expect[y, x], se[y, x], bound[y, x])
    bad = where[..., None] & (excess > K_ALL * se)
    assert not bad.any(), [(tuple(i), got[tuple(i)], expect[tuple(i)], se[tuple(i)])
                           for i in np.argwhere(bad)[:5]]
    moving = where[..., None] & (se > 0)
    assert moving.sum() > 20
    assert np.median(excess[moving] / se[moving]) < MEDIAN_MAX


def test_sharp_instants_are_the_official_lite_renderer(tmp_path):
    """(a) at four times: every pixel's colour and alpha within 1e-4 of the reference, over a
    grey background (the official background is black; a coloured one shows alpha)."""
    W, H = 64, 48
    R, C, f = mixed_camera(W, H)
    bg = (0.1, 0.2, 0.3)
    scene, raw = write_scene(tmp_path, mixed_model(), R, C, f, W, H, bg)
    for t in SHARP_TIMES:
        img = read_exr(render(scene, tmp_path / f"sharp{t}.exr", "--time", t))[0]
        expect, T = stg.render_instant(raw, t, R, C, f, f, W, H, bg)
        err = np.abs(img[..., :3] - expect)
        assert err.max() < TOL, (t, err.max(), np.unravel_index(err.argmax(), err.shape))
        assert np.abs(img[..., 3] - (1 - T)).max() < TOL, t
        assert (T < 0.99).sum() > 1000 and (T < 0.5).sum() > 40  # the Gaussians are there


def test_a_zero_rot_gaussian_is_drawn_with_the_identity_and_a_tiny_rot_scaled_as_torch_does(tmp_path):
    """rot = 0 (error-guided sampling's Gaussians): normalize keeps 0 and the CUDA's matrix of 0 is
    the identity. 0 < |rot| < 1e-12: torch's normalize divides by its eps 1e-12, not by |rot|, so
    q = rot * 1e12 is not a unit quaternion and the CUDA uses it as it is (here |q| = 0.6 about y:
    R = diag(0.28, 1, 0.28), not a half turn)."""
    W, H = 40, 30
    R, C, f = np.eye(3), np.zeros(3), 30.0
    raw = stack([gaussian((-0.5, 0.0, 3.0), (0.9, 0.5, 0.1), 0.8, (0.6, 0.15, 0.3), rot=(0, 0, 0, 0),
                          motion=(0.2, 0, 0, 0, 0, 0, 0, 0, 0)),
                 gaussian((0.6, 0.1, 3.5), (0.1, 0.6, 0.9), 0.8, (0.6, 0.15, 0.3), rot=(0, 0, 6e-13, 0),
                          omega=(0, 0, 0, 0))])
    scene, raw = write_scene(tmp_path, raw, R, C, f, W, H)
    img = read_exr(render(scene, tmp_path / "tiny.exr", "--time", 0.25))[0]
    expect, T = stg.render_instant(raw, 0.25, R, C, f, f, W, H)
    assert np.abs(img[..., :3] - expect).max() < TOL
    assert np.abs(img[..., 3] - (1 - T)).max() < TOL


def test_the_shutter_integral_is_the_average_of_the_instants_unclamped(tmp_path):
    """(b) sampled time over the shutter [0.2, 0.7] (not [0, 1]: model times are scene times)
    against the midpoint rule of the reference's instants, no clamp: the scene has colours above
    1 where the average of clamped instants differs by more than 0.05 (test_stg_reference.py)."""
    W, H = 32, 24
    R, C, f = mixed_camera(W, H)
    scene, raw = write_scene(tmp_path, mixed_model(), R, C, f, W, H)
    expect, bound = fine_average_with_bound(raw, R, C, f, W, H)
    ch, header = render_integral(tmp_path, scene, W, H, 48)
    named = [tuple(int(v) for v in np.unravel_index(np.argmax(expect[..., c]), (H, W)))[::-1] for c in range(3)]
    assert_within_errors(ch, expect, bound, named)


def test_one_flat_gaussian_integrates_to_the_closed_form(tmp_path):
    """(c) the flat Gaussian's streak (four rows, a crop window), Sobol' times: at the named pixels
    within K = 4 standard errors of the erf closed form, every pixel of the rows within K_ALL. The
    last named pixel lies where alpha barely passes 1/255: there the cut shortens the interval."""
    R, C = np.eye(3), np.zeros(3)
    scene, raw = write_scene(tmp_path, flat_model(), R, C, FLAT_F, FLAT_W, FLAT_H)
    expect = np.zeros((FLAT_H, FLAT_W, 4))
    for y in range(FLAT_H):
        for x in range(FLAT_W):
            rgb, a = stg.single_gaussian_integral(raw, FLAT_F, FLAT_F, FLAT_W, FLAT_H, x, y, *SHUTTER)
            expect[y, x] = (*rgb, a)
    ch, _ = render_integral(tmp_path, scene, FLAT_W, FLAT_H, 512, "sobol", rows=FLAT_ROWS, name="flat")
    rows = np.zeros((FLAT_H, FLAT_W), bool)
    rows[FLAT_ROWS[0]:FLAT_ROWS[1]] = True
    assert_within_errors(ch, expect, np.zeros_like(expect), [p for p in FLAT_PIXELS if rows[p[1], p[0]]], rows)


def test_clamped_instants_mode_averages_each_instant_clamped_to_one(tmp_path):
    """(d) the clamped-instants mode (official test.py:131 clamps each rendered instant to [0, 1]):
    sharp, the clamped reference within 1e-4; over the shutter, the average of clamped instants
    (which differs from the clamped average and from the plain average here: test_stg_reference.py)."""
    W, H = 32, 24
    R, C, f = mixed_camera(W, H)
    scene, raw = write_scene(tmp_path, mixed_model(), R, C, f, W, H)
    for t in (0.31, 0.62):
        img = read_exr(render(scene, tmp_path / f"clamped{t}.exr", "--time", t, CLAMP_OPTION))[0]
        expect, _ = stg.render_instant(raw, t, R, C, f, f, W, H, clamp=True)
        assert np.abs(img[..., :3] - expect).max() < TOL, t
    expect, bound = fine_average_with_bound(raw, R, C, f, W, H, clamp=True)
    ch, _ = render_integral(tmp_path, scene, W, H, 48, extra=[CLAMP_OPTION], name="clamped")
    named = [tuple(int(v) for v in np.unravel_index(np.argmax(expect[..., c]), (H, W)))[::-1] for c in range(3)]
    assert_within_errors(ch, expect, bound, named)
