"""scripts/convert_checkpoint.py (gsplat v1.5.3 and nerfstudio v1.1.5 splatfacto checkpoints to the
Inria PLY) and nerfstudio's exported PLYs read directly (src/formats/gaussian_ply.c).

The checkpoints are written as torch.save writes them (a zip with <name>/data.pkl, protocol 2, and
data/<key> storages; torch when `import torch` works, else test_convert_4dgs.py's writer of that
layout with stand-in torch modules), holding what the trainers save: gsplat's
{"step", "splats": ParameterDict.state_dict()} (simple_trainer.py:768-781) and nerfstudio's
{"step", "pipeline": state_dict with "_model.gauss_params.*", "optimizers", ...} (trainer.py:467-476).
Each converted PLY is rendered and compared bit for bit with an Inria PLY written here by hand from
the documented mapping (GAUSSIANS.md, the script's docstring): f_dc from sh0 / features_dc, f_rest
channel-major (f_rest_<c (K-1) + k-1> = coefficient k of channel c, written by explicit loops), the
log scales, logit opacities and quaternions as stored; a splatfacto sh_degree 0 model's logit colour
as (sigmoid - 0.5) / C0. The scene is first shown to tell the f_rest order apart: the same model
with f_rest point-major renders differently.

gsplat's export_splats PLY renders as the converted checkpoint. nerfstudio's `ns-export
gaussian-splat` PLYs are written as its exporter writes them (exporter.py:
508-563, 575-606: comments, nx ny nz, float or uchar per property, interleaved): the SH layout
renders as the hand-written Inria PLY; the RGB layout (uchar red/green/blue, no f_dc/f_rest) renders
as the SH PLY with f_dc = (u/255 - 0.5) / C0, splatfacto's RGB2SH of the colour it draws.

Hostile checkpoints (neither layout, a missing or misshapen parameter, counts that differ, an SH
count of no degree, a storage declaring 2^39 elements, a pickle naming os.system) are refused in one
line naming the file, exit 1, nothing written, under a 2 GiB address-space limit."""
import collections
import os
import resource
import subprocess

import numpy as np
import pytest

from conftest import ROOT, sharp_gaussian_render
import gsply
from test_convert_4dgs import FakeStorage, FakeTensor, fake_torch_save, refused

SCRIPT = str(ROOT / "scripts" / "convert_checkpoint.py")
C0 = 0.28209479177387814  # Y_0^0 = 1 / (2 sqrt(pi))
W = H = 32


def torch_available():
    try:
        import torch  # noqa: F401
        return True
    except ImportError:
        return False


def state_dict(tensors):
    """An OrderedDict with torch's _metadata attribute, as Module.state_dict() returns."""
    sd = collections.OrderedDict(tensors)
    sd._metadata = collections.OrderedDict([("", {"version": 1})])
    return sd


def map_arrays(v, leaf):
    """v with each numpy array replaced by leaf(array), dicts (their type and torch's _metadata kept) and
    lists walked."""
    if isinstance(v, np.ndarray):
        return leaf(v)
    if isinstance(v, dict):
        out = type(v)((k, map_arrays(x, leaf)) for k, x in v.items())
        if hasattr(v, "_metadata"):
            out._metadata = v._metadata
        return out
    return [map_arrays(x, leaf) for x in v] if isinstance(v, list) else v


def save(path, obj):
    """torch.save(obj, path), float32 arrays as tensors."""
    if torch_available():
        import torch
        torch.save(map_arrays(obj, lambda v: torch.from_numpy(np.ascontiguousarray(v, np.float32))), path)
        return
    storages = []

    def fake(v):
        st = FakeStorage(str(len(storages)), v.ravel())
        storages.append(st)
        strides = [int(np.prod(v.shape[i + 1:])) for i in range(v.ndim)]  # C order, as torch
        return FakeTensor(st, 0, v.shape, strides)
    fake_torch_save(path, map_arrays(obj, fake), storages)


def random_model(seed, n, degree):
    """Stored (pre-activation) float32 parameters: log scales, logit opacities, raw quaternions."""
    rng = np.random.default_rng(seed)
    f = lambda a: np.asarray(a, np.float32)
    return {"means": f(rng.uniform(-0.6, 0.6, (n, 3))), "scales": f(np.log(rng.uniform(0.06, 0.3, (n, 3)))),
            "quats": f(rng.normal(size=(n, 4))), "opacities": f(rng.uniform(-1.5, 1.0, n)),
            "sh": f(rng.normal(0, 0.5, (n, (degree + 1) ** 2, 3)))}


def gsplat_checkpoint(path, m, **override):
    splats = {"means": m["means"], "scales": m["scales"], "quats": m["quats"], "opacities": m["opacities"],
              "sh0": m["sh"][:, :1, :], "shN": m["sh"][:, 1:, :]}
    splats.update(override)
    save(path, {"step": 29999, "splats": state_dict({k: v for k, v in splats.items() if v is not None})})


def nerfstudio_checkpoint(path, m, prefix="_model.gauss_params.", **override):
    n = len(m["means"])
    params = {"means": m["means"], "scales": m["scales"], "quats": m["quats"],
              "features_dc": m["sh"][:, 0, :], "features_rest": m["sh"][:, 1:, :],
              "opacities": m["opacities"][:, None]}
    params.update(override)
    pipeline = {prefix + k: v for k, v in params.items() if v is not None}
    pipeline["_model.camera_optimizer.pose_adjustment"] = np.zeros((3, 6), np.float32)
    pipeline["_model.background_color"] = np.array([0.1, 0.2, 0.3], np.float32)
    adam = {"state": {0: {"step": np.array(30000.0, np.float32), "exp_avg": np.zeros((n, 3), np.float32)}},
            "param_groups": [{"lr": 1.6e-6, "betas": (0.9, 0.999), "eps": 1e-15, "params": [0]}]}
    save(path, {"step": 29999, "pipeline": state_dict(pipeline), "optimizers": {"means": adam},
                "schedulers": {"means": {"base_lrs": [1.6e-4], "last_epoch": 29999, "_step_count": 30000}},
                "scalers": {"scale": 65536.0, "growth_factor": 2.0, "_growth_tracker": 0}})


def write_ply(path, props, n, comments=()):
    """A binary little-endian PLY of (name, 'float'|'uchar', column) in order, interleaved per vertex."""
    dtype = np.dtype([(name, "<f4" if kind == "float" else "u1") for name, kind, _ in props])
    rows = np.zeros(n, dtype)
    for name, _, col in props:
        rows[name] = col
    head = ["ply", "format binary_little_endian 1.0", *[f"comment {c}" for c in comments], f"element vertex {n}"]
    head += [f"property {kind} {name}" for name, kind, _ in props] + ["end_header"]
    path.write_bytes(("\n".join(head) + "\n").encode() + rows.tobytes())


def hand_inria_ply(path, m, dc=None, point_major=False):
    """The documented mapping, written without the converter: f_rest channel-major by loops."""
    n, k = m["sh"].shape[0], m["sh"].shape[1]
    sh = m["sh"]
    dc = sh[:, 0, :] if dc is None else dc
    props = [(a, "float", m["means"][:, i]) for i, a in enumerate("xyz")]
    props += [(a, "float", np.zeros(n)) for a in ("nx", "ny", "nz")]
    props += [(f"f_dc_{c}", "float", dc[:, c]) for c in range(3)]
    for c in range(3):
        for j in range(1, k):
            index = (j - 1) * 3 + c if point_major else c * (k - 1) + (j - 1)
            props.append((f"f_rest_{index}", "float", sh[:, j, c]))
    props.sort(key=lambda p: int(p[0][7:]) if p[0].startswith("f_rest_") else -1)  # keeps x..f_dc first
    props += [("opacity", "float", m["opacities"])] + [(f"scale_{i}", "float", m["scales"][:, i]) for i in range(3)]
    props += [(f"rot_{i}", "float", m["quats"][:, i]) for i in range(4)]
    write_ply(path, props, n)


def convert(ckpt, out):
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
    try:
        return subprocess.run(["/usr/bin/python3", SCRIPT, str(ckpt), "-o", str(out)], capture_output=True,
                              text=True, timeout=60, preexec_fn=limit,
                              env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    except subprocess.TimeoutExpired:
        pytest.fail("the converter did not finish within 60 s (it hangs)")


CAMERA = gsply.camera_xml(gsply.rotation(0.3, -0.2), -2.5 * gsply.rotation(0.3, -0.2)[:, 2], 30.0, W, H)


def render_ply(tmp_path, ply, name):
    return sharp_gaussian_render(tmp_path, CAMERA, ply, ' semantics="gsplat"', name=name)


def check_renders_as_hand_written(tmp_path, ckpt, m, dc=None):
    out, hand = tmp_path / "converted.ply", tmp_path / "hand.ply"
    proc = convert(ckpt, out)
    assert proc.returncode == 0, proc.stderr
    assert 'semantics="gsplat"' in proc.stdout and "gsplat-antialiased" in proc.stdout, proc.stdout
    assert f'<gaussianModel file="{out}" semantics="gsplat"/>' in proc.stdout and "frame" in proc.stdout
    hand_inria_ply(hand, m, dc)
    got, want = render_ply(tmp_path, out, "converted"), render_ply(tmp_path, hand, "hand")
    assert np.array_equal(got, want)
    return want


@pytest.mark.parametrize("degree", [1, 3])
def test_a_gsplat_checkpoint_renders_as_the_inria_ply_written_by_hand(tmp_path, degree):
    m = random_model(5 + degree, 14, degree)
    gsplat_checkpoint(tmp_path / "ckpt_29999_rank0.pt", m)
    want = check_renders_as_hand_written(tmp_path, tmp_path / "ckpt_29999_rank0.pt", m)
    hand_inria_ply(tmp_path / "point_major.ply", m, point_major=True)  # the scene tells the orders apart
    assert np.abs(render_ply(tmp_path, tmp_path / "point_major.ply", "pm") - want).max() > 1e-3


def test_a_nerfstudio_checkpoint_renders_as_the_inria_ply_written_by_hand(tmp_path):
    m = random_model(11, 14, 3)
    nerfstudio_checkpoint(tmp_path / "step-000029999.ckpt", m)
    check_renders_as_hand_written(tmp_path, tmp_path / "step-000029999.ckpt", m)


@pytest.mark.parametrize("prefix", ["_model.gauss_params.", "_model.module.gauss_params.", "_model."])
def test_a_splatfacto_sh_degree_0_model_draws_the_sigmoid_of_its_logit_colour(tmp_path, prefix):
    """sh_degree 0: features_rest is [N, 0, 3] and the colour sigmoid(features_dc) (splatfacto.py:593-597)."""
    m = random_model(3, 10, 0)
    nerfstudio_checkpoint(tmp_path / "c.ckpt", m, prefix=prefix)
    dc = (1 / (1 + np.exp(-m["sh"][:, 0, :].astype(np.float64))) - 0.5) / C0
    check_renders_as_hand_written(tmp_path, tmp_path / "c.ckpt", m, dc=dc)


def nerfstudio_export(path, m, colour_mode):
    """A PLY as nerfstudio v1.1.5's ExportGaussianSplat writes it (exporter.py:575-606)."""
    n, k = m["sh"].shape[:2]
    props = [(a, "float", m["means"][:, i]) for i, a in enumerate("xyz")]
    props += [(a, "float", np.zeros(n)) for a in ("nx", "ny", "nz")]
    if colour_mode == "rgb":  # (clamp(SH2RGB(features_dc), 0, 1) * 255).astype(uint8)
        rgb = np.clip(m["sh"][:, 0, :].astype(np.float32) * np.float32(C0) + np.float32(0.5), 0, 1)
        u8 = (rgb * 255).astype(np.uint8)
        props += [(c, "uchar", u8[:, i]) for i, c in enumerate(("red", "green", "blue"))]
    else:
        props += [(f"f_dc_{c}", "float", m["sh"][:, 0, c]) for c in range(3)]
        rest = m["sh"][:, 1:, :].transpose(0, 2, 1).reshape(n, -1)
        props += [(f"f_rest_{i}", "float", rest[:, i]) for i in range(rest.shape[1])]
    props += [("opacity", "float", m["opacities"])] + [(f"scale_{i}", "float", m["scales"][:, i]) for i in range(3)]
    props += [(f"rot_{i}", "float", m["quats"][:, i]) for i in range(4)]
    write_ply(path, props, n, ["Generated by Nerstudio 1.1.5", "Vertical Axis: z"])
    return u8 if colour_mode == "rgb" else None


def test_nerfstudio_exports_render_as_the_inria_ply_in_both_colour_layouts(tmp_path):
    m = random_model(21, 14, 3)
    nerfstudio_export(tmp_path / "sh.ply", m, "sh_coeffs")
    hand_inria_ply(tmp_path / "hand.ply", m)
    sh_render = render_ply(tmp_path, tmp_path / "sh.ply", "sh")
    assert np.array_equal(sh_render, render_ply(tmp_path, tmp_path / "hand.ply", "h"))
    u8 = nerfstudio_export(tmp_path / "rgb.ply", m, "rgb")
    assert len(np.unique(u8)) > 20  # the colours vary: a wrong mapping would show
    m0 = dict(m, sh=m["sh"][:, :1, :])
    hand_inria_ply(tmp_path / "rgb_as_sh.ply", m0, dc=(u8 / 255.0 - 0.5) / C0)
    got = render_ply(tmp_path, tmp_path / "rgb.ply", "rgb")
    assert np.array_equal(got, render_ply(tmp_path, tmp_path / "rgb_as_sh.ply", "rgbsh"))


def test_gsplats_own_export_renders_as_the_converted_checkpoint(tmp_path):
    """export_splats(format="ply") (gsplat v1.5.3 exporter.py:385-405, 513): no normals, f_rest from
    shN.permute(0, 2, 1), the rest as stored: the converter's PLY draws the same image."""
    m = random_model(31, 14, 2)
    n = len(m["means"])
    props = [(a, "float", m["means"][:, i]) for i, a in enumerate("xyz")]
    props += [(f"f_dc_{c}", "float", m["sh"][:, 0, c]) for c in range(3)]
    rest = m["sh"][:, 1:, :].transpose(0, 2, 1).reshape(n, -1)
    props += [(f"f_rest_{i}", "float", rest[:, i]) for i in range(rest.shape[1])]
    props += [("opacity", "float", m["opacities"])] + [(f"scale_{i}", "float", m["scales"][:, i]) for i in range(3)]
    props += [(f"rot_{i}", "float", m["quats"][:, i]) for i in range(4)]
    write_ply(tmp_path / "point_cloud_29999.ply", props, n)
    gsplat_checkpoint(tmp_path / "ckpt_29999_rank0.pt", m)
    proc = convert(tmp_path / "ckpt_29999_rank0.pt", tmp_path / "converted.ply")
    assert proc.returncode == 0, proc.stderr
    assert np.array_equal(render_ply(tmp_path, tmp_path / "point_cloud_29999.ply", "e"),
                          render_ply(tmp_path, tmp_path / "converted.ply", "c"))


def test_rgb_colours_beside_f_rest_without_f_dc_are_refused(tmp_path, render):
    m = random_model(2, 3, 1)
    n = 3
    props = [(a, "float", m["means"][:, i]) for i, a in enumerate("xyz")]
    props += [(c, "uchar", np.full(n, 100)) for c in ("red", "green", "blue")]
    props += [(f"f_rest_{i}", "float", np.zeros(n)) for i in range(9)]
    props += [("opacity", "float", m["opacities"])] + [(f"scale_{i}", "float", m["scales"][:, i]) for i in range(3)]
    props += [(f"rot_{i}", "float", m["quats"][:, i]) for i in range(4)]
    write_ply(tmp_path / "bad.ply", props, n)
    proc = render(f'<scene><camera position="0 0 3" lookat="0 0 0" up="0 1 0" fov="40" width="8" height="8"/>'
                  f'<object name="g"><gaussianModel file="{tmp_path / "bad.ply"}"/></object></scene>', check=False)
    assert proc.returncode != 0 and "red/green/blue and f_rest_*" in proc.stderr and "bad.ply" in proc.stderr


def huge_storage(path):
    """A means tensor viewing a storage that declares 2^39 floats, its member holding 12 bytes."""
    storages = [FakeStorage("0", np.zeros(3), numel=1 << 39)]
    tensor = FakeTensor(storages[0], 0, (1 << 37, 3), (3, 1))
    fake_torch_save(path, {"step": 1, "splats": collections.OrderedDict(means=tensor)}, storages)


HOSTILE = {
    "neither layout": (lambda p, m: save(p, {"step": 1, "model": state_dict({"w": m["means"]})}),
                       ["neither 'splats'", "keys are step, model"]),
    "missing shN": (lambda p, m: gsplat_checkpoint(p, m, shN=None), ["splats['shN']", "not a tensor"]),
    "scales [N,2]": (lambda p, m: gsplat_checkpoint(p, m, scales=m["scales"][:, :2]),
                     ["splats['scales']", "expected (12, 3)"]),
    "counts differ": (lambda p, m: gsplat_checkpoint(p, m, opacities=m["opacities"][:-1]), ["splats['opacities']"]),
    "SH of no degree": (lambda p, m: gsplat_checkpoint(p, m, shN=np.tile(m["sh"][:, 1:, :], (1, 2, 1))),
                        ["no SH degree"]),
    "not splatfacto": (lambda p, m: save(p, {"pipeline": state_dict({"_model.field.w": m["means"]})}),
                       ["_model.gauss_params.means"]),
    "ns quats [N,3]": (lambda p, m: nerfstudio_checkpoint(p, m, quats=m["quats"][:, :3]),
                       ["quats'", "expected (12, 4)"]),
    "non-finite": (lambda p, m: gsplat_checkpoint(p, m, means=np.where(np.arange(12)[:, None] == 4, np.inf,
                                                                       m["means"]).astype(np.float32)),
                   ["Gaussian 4", "'x'"]),
    "zero quaternion": (lambda p, m: gsplat_checkpoint(p, m, quats=np.where(np.arange(12)[:, None] == 7, 0,
                                                                           m["quats"]).astype(np.float32)),
                        ["Gaussian 7", "quaternion is zero"]),
    "2^39 elements": (lambda p, m: huge_storage(p), ["declares", "bytes"]),
    "os.system": (lambda p, m: fake_torch_save(p, "x", [], placeholder=("x", b"cos\nsystem\n(S'touch MARKER'\ntR")),
                  ["os.system", "not on the allow-list"]),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_a_hostile_checkpoint_is_refused_in_one_line_and_nothing_is_written(tmp_path, case, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a payload's `touch MARKER` would land here
    make, words = HOSTILE[case]
    ckpt, out = tmp_path / "ckpt.pt", tmp_path / "out.ply"
    make(ckpt, random_model(1, 12, 1))
    before = ckpt.read_bytes()
    proc = convert(ckpt, out)
    refused(proc, *words, name=ckpt)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ckpt.pt"] and ckpt.read_bytes() == before


def test_drop_nonfinite_drops_the_gaussians_both_exporters_drop(tmp_path):
    m = random_model(8, 12, 1)
    m["means"][4, 1], m["sh"][9, 2, 0] = np.nan, np.inf
    gsplat_checkpoint(tmp_path / "c.pt", m)
    refused(convert(tmp_path / "c.pt", tmp_path / "out.ply"), "Gaussian 4", "'y'", "2 Gaussians", "--drop-nonfinite")
    proc = subprocess.run(["/usr/bin/python3", SCRIPT, str(tmp_path / "c.pt"), "-o", str(tmp_path / "out.ply"),
                           "--drop-nonfinite"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and "10 Gaussians" in proc.stdout and "2 holding" in proc.stdout, proc.stderr
    keep = np.setdiff1d(np.arange(12), [4, 9])
    hand_inria_ply(tmp_path / "hand.ply", {k: v[keep] for k, v in m.items()})
    got = render_ply(tmp_path, tmp_path / "out.ply", "o")
    assert np.array_equal(got, render_ply(tmp_path, tmp_path / "hand.ply", "h"))


def test_the_checkpoint_is_never_the_output(tmp_path):
    ckpt = tmp_path / "ckpt.pt"
    gsplat_checkpoint(ckpt, random_model(1, 4, 0))
    before = ckpt.read_bytes()
    proc = convert(ckpt, ckpt)
    assert proc.returncode == 1 and str(ckpt) in proc.stderr and ckpt.read_bytes() == before


def test_a_2dgs_trainers_checkpoint_name_gets_a_warning_and_a_3dgs_one_none(tmp_path):
    """simple_trainer_2dgs.py saves the same keys as ckpt_<step>.pt (724-730), simple_trainer.py as
    ckpt_<step>_rank<r>.pt (779-781): only the name tells them apart."""
    m = random_model(4, 5, 1)
    for name, warned in (("ckpt_6999.pt", True), ("ckpt_6999_rank0.pt", False)):
        gsplat_checkpoint(tmp_path / name, m)
        proc = convert(tmp_path / name, tmp_path / (name + ".ply"))
        assert proc.returncode == 0 and (tmp_path / (name + ".ply")).exists(), proc.stderr
        assert ("rasterization_2dgs" in proc.stderr) == warned and len(proc.stderr.splitlines()) == warned
