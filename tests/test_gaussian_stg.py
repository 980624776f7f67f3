"""A SpacetimeGaussians "lite" model (its Gaussians move; the layout of
oppo-us-research/SpacetimeGaussians 427abfc5 scene/ourslite.py save_ply,
lines 335-387) through the renderer's object placement and refusals.
Each instant of such a model is, by the official renderer's construction
(renderer/__init__.py:318-343 hands the rasterizer static Gaussians), the
static 3DGS model of its Gaussians at that time: so a sharp render of the
STG file at t equals the sharp render of a static 3DGS file holding the
states at t (tests/stg_reference.py's stg_lite_at; colours as SH DC
coefficients whose +0.5 gives the same RGB), also when the object is
placed and turns. Against the official rasterizer itself:
tests/test_stg_lite.py; the evaluation and the bounds:
tests/test_gaussian_dynamic.c."""
import numpy as np

import gsply
import stg_reference as stg
from conftest import read_exr, render_bit_identical_across_threads_and_passes, run

SH_C0 = 0.28209479177387814
W, H, F = 48, 32, 80.0
NAMES = (["x", "y", "z", "trbf_center", "trbf_scale", "nx", "ny", "nz"] + [f"motion_{i}" for i in range(9)] +
         ["f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2"] +
         [f"rot_{i}" for i in range(4)] + [f"omega_{i}" for i in range(4)])


def write_stg_lite(path, n=4, cubic=0.0):
    """n Gaussians about the object's origin, moving along x and turning, as float32 binary
    little endian (the stored values, no activation); cubic: motion_6 of the last one."""
    v = np.zeros((n, len(NAMES)))
    col = {p: i for i, p in enumerate(NAMES)}
    v[:, col["x"]] = np.linspace(-0.5, 0.5, n)
    v[:, col["y"]] = np.linspace(0.2, -0.2, n)
    v[:, col["trbf_center"]] = np.linspace(0.2, 0.7, n)
    v[:, col["trbf_scale"]] = np.log(0.6)
    v[:, col["motion_0"]] = 1.0
    v[:, col["motion_4"]] = -0.5           # D^2 along y
    v[-1, col["motion_6"]] = cubic
    v[:, col["f_dc_0"]] = np.linspace(0.2, 0.9, n)
    v[:, col["f_dc_1"]] = 0.4
    v[:, col["f_dc_2"]] = np.linspace(0.8, 0.1, n)
    v[:, col["opacity"]] = 1.5
    v[:, [col["scale_0"], col["scale_1"], col["scale_2"]]] = np.log([0.12, 0.05, 0.08])
    v[:, col["rot_0"]], v[:, col["rot_2"]] = 1.0, 0.3
    v[:, col["omega_1"]], v[:, col["omega_3"]] = 1.2, -0.7
    head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    head += "".join(f"property float {p}\n" for p in NAMES) + "end_header\n"
    path.write_bytes(head.encode() + v.astype("<f4").tobytes())


def scene(tmp_path, name, ply, placement):
    path = tmp_path / f"{name}.xml"
    path.write_text(f'<scene>{gsply.camera_xml(np.eye(3), np.zeros(3), F, W, H)}<background color="0.1 0.2 0.3"/>'
                    f'<object name="g" position="0 0 4"><gaussianModel file="{ply}"/>{placement}</object></scene>')
    return path


def sharp(path, t, out):
    proc = run([path, "--time", t, "--pixel-filter", "point", "--spp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    return read_exr(out)[0]


def test_an_instant_is_the_static_3dgs_model_of_its_gaussians_then(tmp_path):
    """At three times, with the object placed still and turning about y: the STG render equals
    the static model of the Gaussians' states then (mean, quaternion, opacity), within float
    rounding of the stored opacity's logit and of the colour's SH coefficient."""
    ply = tmp_path / "stg.ply"
    write_stg_lite(ply)
    raw = stg.read_stg_lite_ply(ply)
    turning = '<animation><rotation axis="0 1 0" center="0 0 4" degrees_per_unit_time="50"/></animation>'
    for placement in ("", turning):
        for t in (0.1, 0.45, 0.9):
            state = stg.stg_lite_at(raw, t)
            still = tmp_path / f"still{t}.ply"
            gsply.write(still, {"mean": state["mean"], "scale": state["scale"], "rot": state["rot"],
                                "opacity": state["opacity"],
                                "sh": ((state["colors_precomp"] - 0.5) / SH_C0)[:, None, :]})
            got = sharp(scene(tmp_path, "stg", ply, placement), t, tmp_path / "stg.exr")
            want = sharp(scene(tmp_path, "still", still, placement), t, tmp_path / "still.exr")
            assert np.abs(got - want).max() < 1e-5, (placement, t, np.abs(got - want).max())
            assert (got[..., 3] > 0.1).sum() > 60, (placement, t)  # the Gaussians are in view


def test_a_gaussian_that_moves_beyond_the_reach_of_rays_is_refused_by_name(tmp_path):
    """A cubic coefficient of 1e20 takes the last Gaussian past 1e15 (RR_MAX_REACH) during the
    shutter: refused naming the file, the Gaussian and the object, nothing written; at an instant
    where it is near, the same model renders."""
    ply = tmp_path / "far.ply"
    write_stg_lite(ply, cubic=1e20)
    path = scene(tmp_path, "far", ply, "")
    out = tmp_path / "x.exr"
    proc = run([path, "--shutter", "0,1", "--spp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 1, proc.stderr
    for part in (str(ply), "Gaussian 3 of object 'g'", "RR_MAX_REACH"):
        assert part in proc.stderr, proc.stderr
    assert not out.exists()
    sharp(path, 0.7, out)  # its trbf_center: D = 0


def test_exact_time_refuses_a_dynamic_model_as_any_gaussian_model(tmp_path):
    ply = tmp_path / "stg.ply"
    write_stg_lite(ply)
    out = tmp_path / "x.exr"
    proc = run([scene(tmp_path, "stg", ply, ""), "--time-integration", "exact", "--spp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 1 and "does not integrate Gaussian-splat objects: use sampled time" in proc.stderr
    assert not out.exists()


def test_moving_gaussians_compose_with_threads_passes_crops_and_a_rolling_shutter(tmp_path):
    """The Gaussians' own motion goes through the same per-ray time as everything else, so the
    render's guarantees hold for it: bit-identical for any thread count and pass split and for a
    crop window's pixels (hits are sorted by key, object and Gaussian, windows are per ray); and
    under a rolling shutter (lineDelay d, src/TRAJECTORIES.md) line r of a sharp render at T is
    line r of the global-shutter render at T + d r, with the object turning meanwhile."""
    ply = tmp_path / "stg.ply"
    write_stg_lite(ply, n=6, cubic=2.0)
    path = scene(tmp_path, "moving", ply, '<animation><rotation axis="0 1 0" degrees_per_unit_time="30"/></animation>')
    common = [path, "--spp", 4, "--tspp", 4, "--batches", 4, "--quiet"]
    img = render_bit_identical_across_threads_and_passes(tmp_path, common, (1, 2))
    crop = tmp_path / "crop.exr"
    assert run([*common, "--crop-window", "0.25,0.75,0.25,0.75", "-o", crop]).returncode == 0
    assert img[..., 3].max() > 0.1  # the Gaussians are in the picture
    assert np.array_equal(read_exr(crop)[0],  # only the window's pixels (pbrt's rounding)
                          img[H // 4:3 * H // 4, W // 4:3 * W // 4])

    d, T = 0.01, 0.3
    rolling = tmp_path / "rolling.xml"
    rolling.write_text(path.read_text().replace("<background", f'<shutter rolling="lines" lineDelay="{d}"/><background'))
    rows = sharp(rolling, T, tmp_path / "rolling.exr")
    still = sharp(path, T, tmp_path / "global.exr")
    drawn = int(np.argmax(still[..., 3].max(axis=1)))  # a line the Gaussians cross at T
    for r in sorted({0, drawn, H // 2, H - 1}):
        line = sharp(path, T + d * r, tmp_path / f"line{r}.exr")[r]
        assert np.array_equal(rows[r], line), r
    assert drawn > 0 and not np.array_equal(rows[drawn], still[drawn])


def test_export_says_the_gaussians_move(tmp_path):
    """refrender export describes the scene for another renderer: a model whose Gaussians move must
    not read as a still 3DGS model there (regression: it said only "kind": "3dgs")."""
    import json
    ply = tmp_path / "stg.ply"
    write_stg_lite(ply)
    out = tmp_path / "scene.json"
    proc = run(["export", scene(tmp_path, "moving", ply, ""), "-o", out])
    assert proc.returncode == 0, proc.stderr
    model = json.loads(out.read_text())["objects"][0]["model"]["gaussians"]
    assert model["motion"] == "stg-lite" and model["kind"] == "3dgs"
