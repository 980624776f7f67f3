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
terms drop when the spatial degree is below 3 (forward.cu:142) or with force_sh_3d.

Hostile inputs need no torch: the tests write checkpoints in torch.save's layout themselves and make
each part hostile (the view, the storage, a zip member, a pickled value, a model value), and run the
converter under a 2 GiB address-space limit with a timeout, so a converter that hangs or asks for
gigabytes fails fast. Each must be refused in one line naming the file (bounded in length), exit 1,
no output; the expectations come from the format (a view's extent, a member's declared size, the
archive's size) and from refrender's reader (src/formats/gaussian_fdgs_ply.c), not from the converter.
An -o that is the checkpoint, however named, or a FIFO/directory is refused and left as it was;
a new PLY gets 0666 less the umask, as open(2) gives a new file."""
import math
import subprocess

import numpy as np
import pytest

import fdgs_reference as fdgs
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


# ---- checkpoints written without torch: hostile inputs ------------------------
#
# torch.save's zip layout (archive/data.pkl, archive/data/<key>, protocol 2, tensors as
# torch._utils._rebuild_tensor_v2(storage, offset, size, stride, ...), storages as persistent ids
# ('storage', torch.FloatStorage, key, location, numel)), written here from that description with
# stand-in modules named torch and torch._utils that exist only while pickling, so any view,
# storage or member can be made as hostile as wanted, and the tests run without python3-torch.

class FakeStorage:
    def __init__(self, key, data, numel=None):
        self.key, self.data = key, np.ascontiguousarray(data, "<f4")
        self.numel = self.data.size if numel is None else numel


class FakeTensor:
    def __init__(self, storage, offset, size, stride):
        self.storage, self.offset, self.size, self.stride = storage, offset, tuple(size), tuple(stride)

    def __reduce__(self):
        import collections
        import sys
        return (sys.modules["torch._utils"]._rebuild_tensor_v2,
                (self.storage, self.offset, self.size, self.stride, False, collections.OrderedDict()))


def fake_tensors(value, storages):
    """value with every float numpy array as a contiguous FakeTensor over a storage of its own."""
    if isinstance(value, np.ndarray):
        st = FakeStorage(str(len(storages)), value.ravel())
        storages.append(st)
        return FakeTensor(st, 0, value.shape, tuple(s // 4 for s in np.array(value, "<f4", order="C").strides))
    if isinstance(value, tuple):
        return tuple(fake_tensors(v, storages) for v in value)
    return value


def fake_torch_save(path, obj, storages, compress=False, placeholder=None):
    """torch.save(obj, path) of FakeTensors; placeholder (name, opcodes) puts raw pickle opcodes
    pushing one object where the string name was pickled."""
    import io
    import pickle
    import struct
    import sys
    import types
    import zipfile
    torch_mod, utils = types.ModuleType("torch"), types.ModuleType("torch._utils")

    def _rebuild_tensor_v2(*args):
        raise AssertionError("never called when writing")
    _rebuild_tensor_v2.__module__, _rebuild_tensor_v2.__qualname__ = "torch._utils", "_rebuild_tensor_v2"
    utils._rebuild_tensor_v2 = _rebuild_tensor_v2
    float_storage = type("FloatStorage", (), {"__module__": "torch", "__qualname__": "FloatStorage"})
    torch_mod.FloatStorage, torch_mod._utils = float_storage, utils

    class Pickler(pickle.Pickler):
        def persistent_id(self, o):
            return ("storage", float_storage, o.key, "cpu", o.numel) if isinstance(o, FakeStorage) else None
    saved = {k: sys.modules.get(k) for k in ("torch", "torch._utils")}
    sys.modules.update({"torch": torch_mod, "torch._utils": utils})
    try:
        buf = io.BytesIO()
        Pickler(buf, protocol=2).dump(obj)
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    data = buf.getvalue()
    if placeholder:
        name, opcodes = placeholder
        pickled = b"X" + struct.pack("<I", len(name)) + name.encode()
        assert data.count(pickled) == 1
        data = data.replace(pickled, opcodes)
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(path, "w", method) as z:
        z.writestr("archive/data.pkl", data)
        z.writestr("archive/byteorder", "little")
        for st in storages:
            z.writestr(f"archive/data/{st.key}", st.data.tobytes())
        z.writestr("archive/version", "3\n")


def simple_capture(n=2, **change):
    """A capture() of n Gaussians with identity 4D rotations (Sigma = diag(exp(2 s))): degree 3 x 2
    (48 coefficients); change replaces entries by CAPTURE name."""
    fields = dict(xyz=np.arange(3 * n, dtype=np.float64).reshape(n, 3), features=np.zeros((n, 48, 3)),
                  scaling=np.log(np.full((n, 3), 0.1)), rotation=np.tile([1.0, 0, 0, 0], (n, 1)),
                  opacity=np.zeros(n), t=np.linspace(1, 2, n), scaling_t=np.full(n, np.log(0.5)),
                  rotation_r=np.tile([1.0, 0, 0, 0], (n, 1)))
    fields.update({k: v for k, v in change.items() if k in fields})
    capture = list(fdgs.make_capture(**fields))
    for index, value in change.get("entries", {}).items():
        capture[index] = value
    return tuple(capture)


def write_fake(path, capture=None, iteration=30000, **kw):
    storages = []
    fake_torch_save(path, (fake_tensors(capture if capture is not None else simple_capture(), storages), iteration),
                    storages, **kw)
    return storages


def convert_limited(ckpt, out, *args, timeout=60, umask=None, flags=ARGS):
    """The converter in an address space of 2 GiB (a converter that asks for many GiB fails
    fast instead of taking the machine), killed after timeout seconds (a hang fails the test)."""
    import os
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
        if umask is not None:
            os.umask(umask)
    try:
        return subprocess.run(["/usr/bin/python3", SCRIPT, str(ckpt), "-o", str(out), "--rotation-convention",
                               "after-900c592", *flags, *args], capture_output=True, text=True, timeout=timeout,
                              preexec_fn=limit, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    except subprocess.TimeoutExpired:
        pytest.fail(f"the converter did not finish within {timeout} s (it hangs)")


def refused(proc, *words, name=None):
    """Exit 1, one line on stderr naming the file (the checkpoint unless name), bounded, with words."""
    lines = proc.stderr.splitlines()
    assert proc.returncode == 1 and len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    assert len(lines[0]) < 1200 and (name is None or str(name) in lines[0]), lines[0][:3000]
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def test_a_checkpoint_written_without_torch_converts_to_the_closed_form(tmp_path):
    """Identity rotations: no velocity, t_var = exp(2 s_t), the scales as given (the fake writer
    is right, so the refusals below are refusals of the hostile part only)."""
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    write_fake(ckpt)
    proc = convert_limited(ckpt, out)
    assert proc.returncode == 0, proc.stderr
    names, cols = read_ply(out)
    np.testing.assert_allclose(cols["t_var"], [0.25, 0.25], rtol=1e-6)
    np.testing.assert_allclose(cols["vel_0"], [0, 0], atol=1e-7)
    np.testing.assert_allclose(np.exp(cols["scale_1"]), [0.1, 0.1], rtol=1e-6)
    np.testing.assert_allclose(cols["t_center"], [1, 2], rtol=1e-7)
    assert names[-1] == "sh4d_143"


def output_cases(tmp_path, ckpt):
    import os
    (tmp_path / "sub").mkdir()
    os.symlink(ckpt, tmp_path / "link.ply")
    os.link(ckpt, tmp_path / "hard.ply")
    return {"same": ckpt, "spelled": tmp_path / "sub" / ".." / ckpt.name, "symlink": tmp_path / "link.ply",
            "hardlink": tmp_path / "hard.ply"}


@pytest.mark.parametrize("case", ["same", "spelled", "symlink", "hardlink"])
def test_an_output_that_is_the_checkpoint_is_refused(tmp_path, case):
    ckpt = tmp_path / "x.pth"
    write_fake(ckpt)
    before = ckpt.read_bytes()
    out = output_cases(tmp_path, ckpt)[case]
    refused(convert_limited(ckpt, out), "input", name=out)
    assert ckpt.read_bytes() == before and ckpt.is_file() and not ckpt.is_symlink()


def test_a_fifo_or_directory_as_output_is_refused_and_kept(tmp_path):
    import os
    import stat
    ckpt, fifo, folder = tmp_path / "x.pth", tmp_path / "out.ply", tmp_path / "dir.ply"
    write_fake(ckpt)
    os.mkfifo(fifo)
    folder.mkdir()
    refused(convert_limited(ckpt, fifo), "FIFO", name=fifo)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    refused(convert_limited(ckpt, folder), "directory", name=folder)
    assert folder.is_dir() and sorted(p.name for p in tmp_path.iterdir()) == ["dir.ply", "out.ply", "x.pth"]


def test_a_device_as_output_is_refused_and_kept(tmp_path):
    """A character device node (1, 3), /dev/null's, made in tmp_path: as root the previous converter
    replaced it with a regular file (as it would /dev/null itself)."""
    import os
    import stat
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root (mknod)")
    ckpt, dev = tmp_path / "x.pth", tmp_path / "null.ply"
    write_fake(ckpt)
    os.mknod(dev, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    refused(convert_limited(ckpt, dev), "device", name=dev)
    assert stat.S_ISCHR(os.stat(dev).st_mode)


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_the_output_gets_the_umask_mode_of_a_new_file(tmp_path, umask, mode):
    import os
    ckpt, out = tmp_path / "x.pth", tmp_path / "m.ply"
    write_fake(ckpt)
    proc = convert_limited(ckpt, out, umask=umask)
    assert proc.returncode == 0, proc.stderr
    assert os.stat(out).st_mode & 0o777 == mode  # open(2): 0666 & ~umask


def test_a_fifo_or_device_as_input_is_refused_without_reading(tmp_path):
    import os
    fifo = tmp_path / "in.pth"
    os.mkfifo(fifo)
    refused(convert_limited(fifo, tmp_path / "a.ply", timeout=30), "FIFO", name=fifo)
    refused(convert_limited("/dev/zero", tmp_path / "b.ply", timeout=30), "device", name="/dev/zero")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.pth"]


def hostile_view(size, stride, offset=0, numel=None):
    """_xyz as a view of a 3-float storage (numel: what the pickle says it holds)."""
    st = FakeStorage("xyz", [1.0, 2.0, 3.0], numel)
    return FakeTensor(st, offset, size, stride), st


@pytest.mark.parametrize("size, stride, offset, words", [
    ((10 ** 9, 3), (0, 1), 0, "zero stride"),  # 2 KB asking for 24 GB as float64
    ((1000, 3), (3, 1), 0, "reaches past its storage"),
    ((-1, 3), (3, 1), 0, "negative"),
    ((1 << 62, 3), (3, 1), 0, "beyond 2^40"),
    ((1, 3), (3, 1), 1, "reaches past its storage"),
])
def test_a_tensor_is_bounded_by_its_storage(tmp_path, size, stride, offset, words):
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    storages = []
    capture = list(fake_tensors(simple_capture(), storages))
    capture[1], st = hostile_view(size, stride, offset)
    fake_torch_save(ckpt, (tuple(capture), 30000), storages + [st])
    refused(convert_limited(ckpt, out), words, name=ckpt)
    assert not out.exists()


def test_a_storage_the_pickle_says_is_larger_than_its_member_is_refused(tmp_path):
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    storages = []
    capture = list(fake_tensors(simple_capture(), storages))
    capture[1], st = hostile_view((10 ** 8, 3), (3, 1), numel=3 * 10 ** 8)
    fake_torch_save(ckpt, (tuple(capture), 30000), storages + [st])
    refused(convert_limited(ckpt, out), "declares 12 bytes", name=ckpt)


def test_a_deflated_member_inflating_far_beyond_its_archive_is_refused_unread(tmp_path):
    """64 MiB of zeros deflate to about 64 KiB: declared, consistent with the pickle, but more than
    4 times the archive's size plus 1 MiB, so it is refused before it is inflated."""
    ckpt, out = tmp_path / "bomb.pth", tmp_path / "m.ply"
    n = (64 << 20) // 12
    write_fake(ckpt, simple_capture(entries={1: np.zeros((n, 3), np.float32)}), compress=True)
    assert ckpt.stat().st_size < 1 << 20
    refused(convert_limited(ckpt, out), "archive's size", name=ckpt)


def test_tensors_viewing_one_storage_read_it_once(tmp_path):
    """Seven entries, views of one 1.4 MB storage at different offsets (as torch saves views of one
    tensor): read once, as torch.load reads a key once, so they stay within the budget of 4x the
    archive's size; counted once per tensor, they would be refused."""
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    n = 20000
    parts = {1: np.random.default_rng(2).normal(size=(n, 3)), 4: np.full((n, 3), np.log(0.1)),
             5: np.tile([1.0, 0, 0, 0], (n, 1)), 6: np.zeros((n, 1)), 13: np.ones((n, 1)),
             14: np.full((n, 1), np.log(0.5)), 15: np.tile([1.0, 0, 0, 0], (n, 1))}
    shared = FakeStorage("shared", np.concatenate([a.ravel() for a in parts.values()]))
    storages = []
    plain = simple_capture(n=n, features=np.zeros((n, 1, 3)), entries={0: 0, 18: 0})
    capture = list(fake_tensors(tuple(None if i in parts else v for i, v in enumerate(plain)), storages))
    offset = 0
    for index, a in parts.items():
        capture[index] = FakeTensor(shared, offset, a.shape, (a.shape[1], 1))
        offset += a.size
    fake_torch_save(ckpt, (tuple(capture), 30000), storages + [shared])
    assert 7 * shared.data.nbytes > 4 * ckpt.stat().st_size + (1 << 20)
    proc = convert_limited(ckpt, out)
    assert proc.returncode == 0, proc.stderr
    names, cols = read_ply(out)
    np.testing.assert_allclose(cols["x"], parts[1][:, 0], rtol=1e-6)
    np.testing.assert_allclose(cols["t_var"], 0.25, rtol=1e-6)


def zip_entries(data):
    """{name: (local header offset, central header offset)} of a zip file's bytes."""
    import struct
    out, pos = {}, 0
    while (pos := data.find(b"PK\x01\x02", pos)) >= 0:
        nlen = struct.unpack_from("<H", data, pos + 28)[0]
        name = data[pos + 46:pos + 46 + nlen].decode()
        out[name] = (struct.unpack_from("<I", data, pos + 42)[0], pos)
        pos += 4
    return out


def damage(path, member, how):
    """Damages one member of a zip in place: the ways zipfile fails reading a member."""
    import struct
    data = bytearray(path.read_bytes())
    local, central = zip_entries(bytes(data))[member]
    nlen, xlen = struct.unpack_from("<HH", data, local + 26)
    start = local + 30 + nlen + xlen
    if how == "crc":  # BadZipFile: Bad CRC-32
        data[start] ^= 0xFF
    elif how == "method":  # NotImplementedError: compression method 99
        struct.pack_into("<H", data, local + 8, 99)
        struct.pack_into("<H", data, central + 10, 99)
    elif how == "encrypted":  # RuntimeError: password required
        for off in (local + 6, central + 8):
            struct.pack_into("<H", data, off, struct.unpack_from("<H", data, off)[0] | 1)
    elif how == "stream":  # zlib.error: invalid deflate data
        data[start:start + 4] = b"\xff\xff\xff\xff"
    elif how == "header":  # BadZipFile: bad local header magic
        data[local:local + 4] = b"PK\x09\x09"
    elif how == "short":  # EOFError: the deflate stream ends early
        csize = struct.unpack_from("<I", data, central + 20)[0]
        for off in (local + 18, central + 20):
            struct.pack_into("<I", data, off, csize // 2)
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("member", ["archive/data.pkl", "archive/data/0"])
@pytest.mark.parametrize("how", ["crc", "method", "encrypted", "stream", "header", "short"])
def test_a_damaged_member_is_refused_in_one_line(tmp_path, member, how):
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    capture = simple_capture(n=200, xyz=np.random.default_rng(1).normal(size=(200, 3)))
    write_fake(ckpt, capture, compress=how in ("stream", "short"))
    damage(ckpt, member, how)
    refused(convert_limited(ckpt, out), member, name=ckpt)
    assert not out.exists()


def nested_list(depth):
    """Pickle opcodes pushing a list nested depth deep: depth EMPTY_LISTs, then depth - 1 APPENDs."""
    return b"]" * depth + b"a" * (depth - 1)


@pytest.mark.parametrize("where", [0, 16, "iteration"])
def test_a_deep_or_huge_value_is_refused_in_a_bounded_line(tmp_path, where):
    """A list nested 200,000 deep or a 20 MB string where an int or True belongs: one line of
    bounded length, no RecursionError."""
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    for value, placeholder in (("PLACEHOLDER", ("PLACEHOLDER", nested_list(200_000))), ("x" * 20_000_000, None)):
        if where == "iteration":
            storages = []
            fake_torch_save(ckpt, (fake_tensors(simple_capture(), storages), value), storages,
                            placeholder=placeholder)
        else:
            write_fake(ckpt, simple_capture(entries={where: value}), placeholder=placeholder)
        refused(convert_limited(ckpt, out), name=ckpt)
        assert not out.exists()


@pytest.mark.parametrize("change, words", [
    (dict(scaling=np.full((2, 3), -400.0)), "capture()[4] _scaling is -400 at Gaussian 0"),
    (dict(scaling_t=np.array([0.0, 150.0])), "capture()[14] _scaling_t is 150 at Gaussian 1"),
    (dict(xyz=np.zeros((0, 3)), features=np.zeros((0, 48, 3)), scaling=np.zeros((0, 3)),
          rotation=np.zeros((0, 4)), opacity=np.zeros(0), t=np.zeros(0), scaling_t=np.zeros(0),
          rotation_r=np.zeros((0, 4))), "no Gaussians"),
    # exp(2 (-60)) = 7.7e-53: a positive float64, 0 as the float32 refrender reads
    (dict(scaling_t=np.array([0.0, -60.0])), "Gaussian 1: 't_var' = 7.66764807e-53 is 0 as a float32"),
    (dict(xyz=np.array([[0, 0, 0], [0, 2e15, 0]])), "Gaussian 1: 'y' = 1.99999997e+15 is beyond 1e15"),
    (dict(scaling=np.array([[0, 0, 0], [0, 0, 40.0]])), "Gaussian 1: 'scale_"),
])
def test_values_refrender_would_refuse_are_refused(tmp_path, change, words):
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    write_fake(ckpt, simple_capture(**change))
    refused(convert_limited(ckpt, out), words, name=ckpt)
    assert not out.exists()


def test_a_time_duration_that_is_0_as_a_float32_is_refused(tmp_path):
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    write_fake(ckpt)
    flags = ["--time_duration", "0", "1e-50", "--prefilter_var", "-1", "--force_sh_3d", "false"]
    proc = convert_limited(ckpt, out, flags=flags)
    assert proc.returncode == 2 and "float32" in proc.stderr and not out.exists(), proc.stderr


def test_an_env_map_model_is_refused_unless_dropped_by_name(tmp_path):
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    write_fake(ckpt, simple_capture(entries={17: np.zeros((3, 4, 4), np.float32)}))
    refused(convert_limited(ckpt, out), "env_map", "--drop-env-map", name=ckpt)
    assert not out.exists()
    proc = convert_limited(ckpt, out, "--drop-env-map")
    assert proc.returncode == 0 and "env_map dropped" in proc.stdout, proc.stderr
    assert b"comment env_map dropped" in out.read_bytes()[:2000]
    write_fake(ckpt, simple_capture(entries={17: None}))  # env_map_res 0: train.py:75 saves None
    assert convert_limited(ckpt, out).returncode == 0


def test_force_sh_3d_with_time_harmonics_is_refused(tmp_path):
    """48 coefficients are 16 x 3 time harmonics: a force_sh_3d model holds (max_sh_degree + 1)^2
    (gaussian_model.py:222-224), so saying force_sh_3d true contradicts the checkpoint."""
    ckpt, out = tmp_path / "c.pth", tmp_path / "m.ply"
    force = ["--time_duration", "0", "10", "--prefilter_var", "-1", "--force_sh_3d", "true"]
    write_fake(ckpt)
    refused(convert_limited(ckpt, out, flags=force), "--force_sh_3d true", "48 coefficients", name=ckpt)
    write_fake(ckpt, simple_capture(features=np.zeros((2, 16, 3))))
    proc = convert_limited(ckpt, out, flags=force)
    assert proc.returncode == 0, proc.stderr
    names, cols = read_ply(out)
    assert names[-1] == "sh4d_47" and set(cols["sh_degree_t"]) == {0}


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
    make_checkpoint(ckpt, edit=lambda c: c[:3] + (c[3].detach()[:, :15],) + c[4:])  # 16: a force_sh_3d model's
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
