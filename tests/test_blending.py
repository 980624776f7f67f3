"""Epsilon-blending (thesis sec. 4.5 step c) and determinism, end to end."""
import numpy as np

from conftest import ROOT, focal_pixels, read_exr, run

W = H = 64
FOV, D = 30.0, 5.0
SIGMA = 0.5


def two_splats(z_blue, eps):
    return f"""<scene>
 <camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="{FOV}" width="{W}" height="{H}"/>
 <render epsilon="{eps}" kernel_sigma="{SIGMA}"/>
 <object><pointModel>
   <splat center="-0.3 0 -{D}" normal="0 0 1" radius="0.6" color="1 0 0"/>
   <splat center="0.3 0 {z_blue}" normal="0 0 1" radius="0.6" color="0 0 1"/>
 </pointModel><material shading="unlit"/></object>
</scene>"""


def expected_blend(sub=8):
    """Per-pixel mean of the kernel-weighted red fraction w1/(w1+w2) over a
    sub x sub grid in each pixel, from the splat definition alone (thesis
    eq. 4.2 and the Gaussian kernel), for points covered by both splats.
    Returns (mean, spread within the pixel, fully-overlapped mask)."""
    f = focal_pixels(H, FOV) / D
    offs = (np.arange(sub) + 0.5) / sub
    y, x = np.mgrid[0:H, 0:W]
    px = (x[..., None, None] + offs[None, None, None, :] - W / 2) / f
    py = (H / 2 - (y[..., None, None] + offs[None, None, :, None])) / f
    r2a = ((px + 0.3) ** 2 + py ** 2) / 0.36
    r2b = ((px - 0.3) ** 2 + py ** 2) / 0.36
    wa, wb = np.exp(-r2a / (2 * SIGMA ** 2)), np.exp(-r2b / (2 * SIGMA ** 2))
    frac = wa / (wa + wb)
    both = (r2a <= 1) & (r2b <= 1)
    full = both.all(axis=(2, 3))
    return frac.mean(axis=(2, 3)), np.ptp(frac, axis=(2, 3)), full


def test_coplanar_splats_blend_with_kernel_weights(render):
    img = render(two_splats(-D, 0.01), "--spp", 16, "--tspp", 1)
    mean, spread, full = expected_blend()
    assert full.sum() > 100
    red = img[:, :, 0][full]
    # a jittered estimate of a pixel average lies within the value range
    assert np.all(np.abs(red - mean[full]) <= spread[full] + 1e-4)
    np.testing.assert_allclose(img[:, :, 0] + img[:, :, 2], img[:, :, 3], atol=1e-6)
    # blending really mixes: red dominates on its side, blue on the other
    assert red.min() < 0.4 and red.max() > 0.6


def test_splats_further_apart_than_epsilon_do_not_blend(render):
    img = render(two_splats(-D - 0.2, 0.1), "--spp", 16, "--tspp", 1)
    _, _, full = expected_blend()
    assert np.all(img[:, :, 2][full] == 0.0)  # only the front (red) splat
    assert np.all(img[:, :, 0][full] == 1.0)
    # within epsilon the same pair blends again
    img = render(two_splats(-D - 0.2, 0.3), "--spp", 16, "--tspp", 1)
    assert np.all(img[:, :, 2][full] > 0.1)


def test_output_is_bit_identical_for_any_thread_count(tmp_path):
    scene = ROOT / "scenes" / "default.xml"
    images = []
    for threads in (1, 2, 3):
        out = tmp_path / f"t{threads}.exr"
        proc = run([scene, "--res", "40x40", "--spp", 4, "--tspp", 6, "--seed", 11,
                    "--threads", threads, "-o", out, "--quiet"])
        assert proc.returncode == 0, proc.stderr
        images.append(read_exr(out)[0])
    assert np.array_equal(images[0], images[1]) and np.array_equal(images[0], images[2])
    out = tmp_path / "other_seed.exr"
    assert run([scene, "--res", "40x40", "--spp", 4, "--tspp", 6, "--seed", 12, "-o", out, "--quiet"]).returncode == 0
    assert not np.array_equal(images[0], read_exr(out)[0])


def static_and_moving_within_eps():
    """A static red splat and a blue splat sliding across it 0.05 behind:
    every covered pixel blends hits from the static and the moving top level."""
    return f"""<scene>
 <camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="{FOV}" width="32" height="32"/>
 <shutter open="0" close="1"/>
 <render epsilon="0.2" kernel_sigma="{SIGMA}"/>
 <object><pointModel>
   <splat center="0 0 -{D}" normal="0 0 1" radius="0.6" color="1 0 0"/>
 </pointModel><material shading="unlit"/></object>
 <object><pointModel>
   <splat center="-0.6 0 -{D + 0.05}" normal="0 0 1" radius="0.6" color="0 0 1"/>
 </pointModel><material shading="unlit"/>
 <animation><linear velocity="1.2 0 0"/></animation></object>
</scene>"""


def test_static_hit_reuse_gives_the_same_image_bit_for_bit(tmp_path):
    """Reusing the static objects' hits across the time samples of a spatial
    sample, and tracing those times together as packets, are optimisations
    only: the image must equal, bit for bit, that of tracing every time
    sample on its own (--no-static-reuse)."""
    cases = [(ROOT / "scenes" / "default.xml", ["--res", "48x48"])]
    mixed = tmp_path / "mixed.xml"
    mixed.write_text(static_and_moving_within_eps())
    cases.append((mixed, []))
    slow = tmp_path / "slow.xml"  # a slow turn: a ray's times stay coherent, so they go as packets
    slow.write_text("""<scene>
 <camera position="0 0 4" lookat="0 0 0" up="0 1 0" fov="40" width="32" height="32"/>
 <shutter open="0" close="1"/> <render epsilon="0.05"/>
 <light type="directional" direction="-1 -1 -1" color="1 1 1"/>
 <object position="0 0 -1.5"><pointModel generate="plane" count="3000" radius="3"/></object>
 <object><pointModel generate="sphere" count="20000" radius="1" checker="6" color2="0.1 0.2 0.9"/>
  <animation><rotation axis="0 1 0" center="0 0 0" degrees_per_unit_time="3"/></animation></object>
</scene>""")
    cases.append((slow, []))
    for scene, extra in cases:
        images = []
        for flag in ([], ["--no-static-reuse"]):
            out = tmp_path / "reuse.exr"
            proc = run([scene, *extra, "--spp", 4, "--tspp", 8, "--seed", 3, "-o", out,
                        "--quiet", *flag])
            assert proc.returncode == 0, proc.stderr
            images.append(read_exr(out)[0])
        assert np.array_equal(images[0], images[1]), scene
        assert images[0][:, :, :3].max() > 0
    # the mixed scene really blends static red with moving blue
    img = images[0]
    assert np.any((img[:, :, 0] > 0.05) & (img[:, :, 2] > 0.05))
