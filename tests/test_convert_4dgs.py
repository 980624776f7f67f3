"""scripts/convert_4dgs.py: real-time 4DGS checkpoints (fudan-zvg/4d-gaussian-splatting,
read at 63725f21) to refrender's PLY.

The checkpoint is a pickle, so reading one must run nothing: pickles naming os.system,
builtins.eval or subprocess.call (by GLOBAL and by a __reduce__), or calling an allow-listed
storage tag, are refused naming module.name, and the marker file the payload would create does not
appear. The rotation convention must be said (checkpoints carry no tag), and a truncated archive is
refused naming the file; no output is left behind on any refusal.

The values: a checkpoint made with torch (Debian's python3-torch) as 4DGS's training saves it,
(capture() tuple, iteration) with Parameters, a strided view and Adam state, converted and checked
against closed forms worked here from the 4D rotation's definition (utils/general_utils.py:113-145):
with left and right quaternions (cos a, 0, 0, sin a) and (cos a, 0, 0, -sin a), M_l M_r is the turn
by 2a in the (x, t) plane, so the velocity is cs(lx - lt)/(s^2 lx + c^2 lt) and the conditional x
variance lx lt/(s^2 lx + c^2 lt); after 900c592 (rows and columns reversed) the velocity changes
sign. With (cos a, sin a, 0, 0) and (cos a, -sin a, 0, 0) it is a turn in the (x, y) plane before
900c592 (no motion) and, reversed, one in the (z, t) plane after it (motion along z): a transpose
instead of the reversal would keep it in (x, y). The covariance is rebuilt from scale/rot with
3DGS's quaternion matrix (general_utils.py:79-100); SH coefficients keep 4DGS's order; the time
terms drop when the spatial degree is below 3 (forward.cu:142) or with force_sh_3d."""
import math
import subprocess

import numpy as np
import pytest

from conftest import ROOT

SCRIPT = str(ROOT / "scripts" / "convert_4dgs.py")
ARGS = ["--time_duration", "0", "10", "--prefilter_var", "-1", "--force_sh_3d", "false"]


def convert(ckpt, out, *args, convention="after-900c592"):
    conv = ["--rotation-convention", convention] if convention else []
    return subprocess.run(["/usr/bin/python3", SCRIPT, str(ckpt), "-o", str(out), *conv, *args],
                          capture_output=True, text=True, timeout=120)


def zip_checkpoint(path, pickled):
    import zipfile
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("archive/data.pkl", pickled)
        z.writestr("archive/version", "3\n")


class Payload:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (subprocess.call, (["touch", self.marker],))


def payloads(marker):
    import pickle
    return {
        "os.system": b"cos\nsystem\n(S'touch %s'\ntR." % marker.encode(),
        "builtins.eval": b"cbuiltins\neval\n(S'open(%r, \"w\")'\ntR." % marker.encode(),
        "subprocess.call": pickle.dumps(((Payload(marker),), 7), protocol=4),
        "torch.FloatStorage": b"ctorch\nFloatStorage\n(S'x'\ntR.",
    }


@pytest.mark.parametrize("name", ["os.system", "builtins.eval", "subprocess.call", "torch.FloatStorage"])
def test_a_malicious_pickle_is_refused_by_name_and_runs_nothing(tmp_path, name):
    marker = tmp_path / "marker"
    ckpt, out = tmp_path / "evil.pth", tmp_path / "out.ply"
    zip_checkpoint(ckpt, payloads(str(marker))[name])
    proc = convert(ckpt, out, *ARGS)
    assert proc.returncode == 1, proc.stderr
    assert name in proc.stderr and str(ckpt) in proc.stderr, proc.stderr
    assert not marker.exists() and not out.exists()
    assert list(tmp_path.iterdir()) == [ckpt]  # no temporary file left either


def test_a_missing_convention_is_refused_naming_both(tmp_path):
    ckpt = tmp_path / "c.pth"
    zip_checkpoint(ckpt, b"N.")
    proc = convert(ckpt, tmp_path / "out.ply", *ARGS, convention=None)
    assert proc.returncode == 2
    for word in ("--rotation-convention", "before-900c592", "after-900c592", "2024-09-15", "no tag"):
        assert word in proc.stderr, proc.stderr
    assert not (tmp_path / "out.ply").exists()


def test_a_truncated_archive_is_refused_naming_the_file(tmp_path):
    import pickle
    whole, ckpt, out = tmp_path / "whole.pth", tmp_path / "cut.pth", tmp_path / "out.ply"
    zip_checkpoint(whole, pickle.dumps(((1, 2), 3), protocol=2) + b"\0" * 4000)
    ckpt.write_bytes(whole.read_bytes()[:len(whole.read_bytes()) // 2])
    proc = convert(ckpt, out, *ARGS)
    assert proc.returncode == 1 and str(ckpt) in proc.stderr and "truncated" in proc.stderr, proc.stderr
    assert not out.exists()


# ---- a real checkpoint -------------------------------------------------------

def torch_or_skip():
    try:
        import torch
    except ImportError as e:
        pytest.skip(f"python3-torch not installed: cannot make a real 4DGS checkpoint ({e}); "
                    "apt-get install python3-torch to run this test")
    return torch


A1, A2 = math.pi / 12, math.pi / 9  # half-angles: turns of 2a
SCALES = np.array([[0.1, 0.2, 0.3, 0.5], [0.2, 0.3, 0.4, 0.5], [0.15, 0.25, 0.35, 0.45]])
L_QUAT = np.array([[1, 0, 0, 0], [2 * math.cos(A1), 0, 0, 2 * math.sin(A1)], [math.cos(A2), math.sin(A2), 0, 0]])
R_QUAT = np.array([[1, 0, 0, 0], [3 * math.cos(A1), 0, 0, -3 * math.sin(A1)],
                   [math.cos(A2), -math.sin(A2), 0, 0]])  # not unit in row 1 (nor is L's): 4DGS normalises
T0 = np.array([2.0, 3.0, 4.0])
N, M = 3, 48


def make_checkpoint(path, active_degree=3, active_degree_t=2, edit=lambda capture: capture):
    """A capture() tuple as scene/gaussian_model.py:116-136 builds it, saved as scene/__init__.py:92 does."""
    torch = torch_or_skip()
    from torch import nn
    feats = torch.tensor([[[1000.0 * n + 10 * m + c for c in range(3)] for m in range(M)] for n in range(N)])
    big_t = torch.tensor([[9.0, t] for t in T0])  # _t as a strided view with an offset
    params = {"xyz": torch.tensor([[1.0, 2.0, 3.0], [-1.0, 0.5, 2.0], [0.0, 0.0, 1.0]]),
              "dc": feats[:, :1, :].clone(), "rest": feats[:, 1:, :].clone(),
              "scaling": torch.tensor(np.log(SCALES[:, :3]), dtype=torch.float32),
              "rotation": torch.tensor(L_QUAT, dtype=torch.float32),
              "opacity": torch.tensor([[0.7], [-1.2], [2.5]]),
              "scaling_t": torch.tensor(np.log(SCALES[:, 3:]), dtype=torch.float32),
              "rotation_r": torch.tensor(R_QUAT, dtype=torch.float32)}
    p = {k: nn.Parameter(v) for k, v in params.items()}
    p["t"] = nn.Parameter(big_t)[:, 1:2]
    shadow = [nn.Parameter(v.detach().clone()) for v in params.values()]
    opt = torch.optim.Adam(shadow, lr=1e-3)
    sum(s.sum() for s in shadow).backward()
    opt.step()
    zeros = torch.zeros((N, 1))
    capture = (active_degree, p["xyz"], p["dc"], p["rest"], p["scaling"], p["rotation"], p["opacity"],
               torch.zeros(N), zeros, zeros, zeros, opt.state_dict(), 1.5, p["t"], p["scaling_t"], p["rotation_r"],
               True, torch.empty(0), active_degree_t)
    torch.save((edit(capture), 30000), path)
    return params


def read_ply(path):
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    head = data[:end].decode().splitlines()
    assert head[1] == "format binary_little_endian 1.0"
    names = [line.split()[2] for line in head if line.startswith("property")]
    assert all(line.startswith("property float ") for line in head if line.startswith("property"))
    count = int(next(line.split()[2] for line in head if line.startswith("element vertex")))
    v = np.frombuffer(data[end:], dtype="<f4").reshape(count, len(names)).astype(np.float64)
    return names, {n: v[:, i] for i, n in enumerate(names)}


def cov_of(cols):
    """3DGS's covariance: R diag(exp(scale))^2 R^T, R of the w-first quaternion (general_utils.py:79-100)."""
    out = []
    for i in range(len(cols["x"])):
        r, x, y, z = (cols[f"rot_{k}"][i] for k in range(4))
        norm = math.sqrt(r * r + x * x + y * y + z * z)
        r, x, y, z = r / norm, x / norm, y / norm, z / norm
        rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - r * z), 2 * (x * z + r * y)],
                        [2 * (x * y + r * z), 1 - 2 * (x * x + z * z), 2 * (y * z - r * x)],
                        [2 * (x * z - r * y), 2 * (y * z + r * x), 1 - 2 * (x * x + y * y)]])
        s2 = np.exp(2 * np.array([cols[f"scale_{k}"][i] for k in range(3)]))
        out.append(rot @ np.diag(s2) @ rot.T)
    return np.array(out)


def expected(convention, prefilter=-1.0):
    """velocity, t_var and conditional covariance per Gaussian, worked by hand (module docstring)."""
    lam = SCALES ** 2
    vel, tvar, cov = np.zeros((N, 3)), np.zeros(N), np.zeros((N, 3, 3))
    # 0: identity rotations
    cov[0], tvar[0] = np.diag(lam[0, :3]), lam[0, 3]
    # 1: a turn by 2 A1 in the (x, t) plane; the reversal turns it by -2 A1
    c, s = math.cos(2 * A1), math.sin(2 * A1)
    lx, ly, lz, lt = lam[1]
    tvar[1] = s * s * lx + c * c * lt
    sign = 1 if convention == "before-900c592" else -1
    vel[1] = [sign * c * s * (lx - lt) / tvar[1], 0, 0]
    cov[1] = np.diag([lx * lt / tvar[1], ly, lz])
    # 2: a turn by 2 A2 in the (x, y) plane before 900c592, in the (z, t) plane after
    c, s = math.cos(2 * A2), math.sin(2 * A2)
    lx, ly, lz, lt = lam[2]
    if convention == "before-900c592":
        tvar[2] = lt
        cov[2] = [[c * c * lx + s * s * ly, c * s * (lx - ly), 0], [c * s * (lx - ly), s * s * lx + c * c * ly, 0],
                  [0, 0, lz]]
    else:
        tvar[2] = s * s * lz + c * c * lt
        vel[2] = [0, 0, -c * s * (lz - lt) / tvar[2]]
        cov[2] = np.diag([lx, ly, lz * lt / tvar[2]])
    return vel, tvar + (prefilter if prefilter > 0 else 0), cov


@pytest.mark.parametrize("convention", ["before-900c592", "after-900c592"])
def test_a_real_checkpoint_converts_to_the_worked_values(tmp_path, convention):
    ckpt, out = tmp_path / "chkpnt30000.pth", tmp_path / "model.ply"
    params = make_checkpoint(ckpt)
    proc = convert(ckpt, out, *ARGS, convention=convention)
    assert proc.returncode == 0, proc.stderr
    names, cols = read_ply(out)
    sh_names = [f"sh4d_{i}" for i in range(3 * 16 * 3)]
    assert names == ["x", "y", "z", "t_center", "vel_0", "vel_1", "vel_2", "t_var", "opacity", "scale_0", "scale_1",
                     "scale_2", "rot_0", "rot_1", "rot_2", "rot_3", "time_duration", "sh_degree",
                     "sh_degree_t"] + sh_names
    vel, tvar, cov = expected(convention)
    tol = dict(rtol=2e-6, atol=2e-7)
    np.testing.assert_allclose(np.stack([cols[f"vel_{k}"] for k in range(3)], 1), vel, **tol)
    np.testing.assert_allclose(cols["t_var"], tvar, **tol)
    np.testing.assert_allclose(cov_of(cols), cov, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(np.stack([cols[k] for k in "xyz"], 1), params["xyz"].numpy(), **tol)
    np.testing.assert_allclose(cols["t_center"], T0, **tol)
    np.testing.assert_allclose(cols["opacity"], params["opacity"].numpy()[:, 0], **tol)
    assert set(cols["time_duration"]) == {10.0} and set(cols["sh_degree"]) == {3} and set(cols["sh_degree_t"]) == {2}
    for i in (0, 1, 5, 47, 48, 100, 143):  # sh4d_<3 (16 k + j) + c> = 4DGS's coefficient 16 k + j, channel c
        m, c = divmod(i, 3)
        np.testing.assert_array_equal(cols[f"sh4d_{i}"], [1000.0 * n + 10 * m + c for n in range(N)])


def test_prefilter_and_the_sh_degrees_that_take_effect(tmp_path):
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    make_checkpoint(ckpt, active_degree=2, active_degree_t=2)
    args = ["--time_duration", "-1", "1.5", "--prefilter_var", "0.3", "--force_sh_3d", "false"]
    proc = convert(ckpt, out, *args)
    assert proc.returncode == 0, proc.stderr
    names, cols = read_ply(out)
    _, tvar, _ = expected("after-900c592", prefilter=0.3)
    np.testing.assert_allclose(cols["t_var"], tvar, rtol=2e-6)
    assert set(cols["time_duration"]) == {2.5} and set(cols["sh_degree"]) == {2} and set(cols["sh_degree_t"]) == {0}
    assert names[-1] == "sh4d_26"  # degree 2 below 3: no time terms (forward.cu:142), 9 coefficients x RGB
    make_checkpoint(ckpt)
    proc = convert(ckpt, out, "--time_duration", "0", "10", "--prefilter_var", "-1", "--force_sh_3d", "true")
    names, cols = read_ply(out)
    assert proc.returncode == 0 and names[-1] == "sh4d_47" and set(cols["sh_degree_t"]) == {0}


@pytest.mark.parametrize("edit, message", [
    (lambda c: c[:12], "capture() has 12 entries: a gaussian_dim 3"),
    (lambda c: c[:14] + (c[14].repeat(1, 2),) + c[15:], "capture()[14] _scaling_t has shape (3, 2), expected (3, 1)"),
    (lambda c: c[:5] + (c[5] * float("nan"),) + c[6:], "capture()[5] _rotation is not finite at Gaussian 0"),
    (lambda c: c[:15] + (c[15] * 0,) + c[16:], "capture()[15] _rotation_r is zero at Gaussian 0"),
    (lambda c: c[:16] + (False,) + c[17:], "capture()[16] rot_4d is False"),
    (lambda c: c[:3] + (c[3][:, :30],) + c[4:],
     "hold 31 coefficients per channel, SH degree 3 x time degree 2 needs 48"),
])
def test_a_checkpoint_that_is_not_a_4dgs_model_is_refused_naming_the_entry(tmp_path, edit, message):
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    make_checkpoint(ckpt, edit=lambda c: edit(tuple(x.detach() if hasattr(x, "detach") else x for x in c)))
    proc = convert(ckpt, out, *ARGS)
    assert proc.returncode == 1 and message in proc.stderr and str(ckpt) in proc.stderr, proc.stderr
    assert not out.exists()


def test_the_legacy_format_is_refused_by_name(tmp_path):
    torch = torch_or_skip()
    ckpt, out = tmp_path / "old.pth", tmp_path / "m.ply"
    torch.save(((1, torch.zeros(3)), 7), ckpt, _use_new_zipfile_serialization=False)
    proc = convert(ckpt, out, *ARGS)
    assert proc.returncode == 1 and "legacy torch.save format" in proc.stderr and not out.exists(), proc.stderr
