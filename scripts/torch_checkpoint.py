"""Reads a torch.save checkpoint (the zip format of torch >= 1.6) without torch
and without running anything in it: the module convert_4dgs.py and
convert_checkpoint.py read their checkpoints with (not a tool).

The pickle is read by a restricted unpickler: it may name only
torch._utils._rebuild_tensor_v2, torch._utils._rebuild_parameter(_with_state),
collections.OrderedDict and torch's typed storage classes (as storage tags);
every other global is refused naming module.name, and nothing in the pickle is
called but those, the rebuilders implemented here in numpy.

A hostile file cannot make the reader hang or ask for much memory:
- the input must be a regular file, refused by name before it is opened (a
  FIFO would block, /dev/zero feed without end), and opened non-blocking;
- the bytes inflated from the archive's members, data.pkl and the storages a
  caller reads together, are bounded by INFLATION_BUDGET times the archive's
  size plus 1 MiB, checked against each member's declared size before it is
  read (torch.save stores members uncompressed, so a real checkpoint reads
  about its own size; a deflated member declaring gigabytes is refused
  without inflating it), and zipfile stops at the declared size;
- data.pkl is at most MAX_PICKLE_BYTES (a 4DGS checkpoint's is a few KB: the
  tensors' data live in their own members);
- a storage's member must hold exactly the element count the pickle gives
  it, and a tensor must lie inside its storage: sizes and strides are
  non-negative, a dimension longer than 1 has a stride of at least 1 (no
  zero-stride views: torch.save writes the parameters 4DGS saves
  contiguous), and its element count is at most its storage's, so a tensor
  read is never larger than the storage it views.
Every refusal is a CheckpointError with a one-line message of bounded length:
values taken from the file are described by type and clipped, never repr'd
whole (a list nested 200,000 deep or a 20 MB string)."""
import collections
import io
import os
import pickle
import stat
import zipfile

import numpy as np

import safefiles

MAX_PICKLE_BYTES = 64 << 20
INFLATION_BUDGET = 4  # times the archive's size (plus 1 MiB): real checkpoints read about 1x
MAX_DIMENSION = 1 << 40  # sizes beyond any real tensor's, refused before any arithmetic on them


class CheckpointError(Exception):
    pass


def clip(text, limit=200):
    """text cut to at most limit characters, saying how long it was."""
    text = str(text)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def describe(value):
    """A value from the file for a message: small scalars as themselves, anything else by type."""
    if value is None or isinstance(value, (bool, int, float)):
        return clip(repr(value), 40)
    if isinstance(value, (str, bytes)):
        return f"a {type(value).__name__} of length {len(value)}"
    if isinstance(value, LazyTensor):
        return f"a tensor of shape {clip(value.shape, 80)}"
    return f"a {type(value).__name__}"


class StorageTag:
    """torch.<T>Storage as a persistent id names it: a dtype, never called."""
    __slots__ = ("name", "dtype")

    def __init__(self, name, dtype):
        self.name, self.dtype = name, dtype

    def __call__(self, *args, **kwargs):
        raise CheckpointError(f"the pickle calls torch.{self.name}, which is allowed only as a storage tag")

    def __setstate__(self, state):
        raise CheckpointError(f"the pickle sets the state of torch.{self.name}")


STORAGE_DTYPES = {"DoubleStorage": "f8", "FloatStorage": "f4", "HalfStorage": "f2", "LongStorage": "i8",
                  "IntStorage": "i4", "ShortStorage": "i2", "CharStorage": "i1", "ByteStorage": "u1",
                  "BoolStorage": "?", "BFloat16Storage": "bf16"}


def itemsize(dtype):
    return 2 if dtype == "bf16" else np.dtype(dtype).itemsize


class LazyStorage:
    """One storage of the archive (data/<key>), read when a tensor needs it."""
    __slots__ = ("archive", "member", "dtype", "numel", "_data")

    def __init__(self, archive, member, dtype, numel):
        self.archive, self.member, self.dtype, self.numel, self._data = archive, member, dtype, numel, None

    def __setstate__(self, state):
        raise CheckpointError("the pickle sets the state of a storage")

    def array(self):
        if self._data is None:
            want = self.numel * itemsize(self.dtype)
            raw = self.archive.read_member(self.member, want)
            if self.dtype == "bf16":  # bfloat16: the high half of a float32
                u16 = np.frombuffer(raw, dtype=self.archive.order + "u2")
                self._data = (u16.astype(np.uint32) << 16).view(np.float32)
            else:
                self._data = np.frombuffer(raw, dtype=np.dtype(self.dtype).newbyteorder(self.archive.order))
        return self._data


class LazyTensor:
    """torch._utils._rebuild_tensor_v2's tensor: a strided view of a storage, read on demand.
    Its bounds are checked when it is rebuilt (check_view)."""
    __slots__ = ("storage", "offset", "shape", "stride")

    def __init__(self, storage, offset, shape, stride):
        self.storage, self.offset, self.shape, self.stride = storage, offset, shape, stride

    def __setstate__(self, state):
        raise CheckpointError("the pickle sets the state of a tensor")

    def numpy(self, floating=np.float64):
        """The tensor as an array (floating dtypes as `floating`: float64 unless a caller that only
        copies values asks for float32, half the memory), never larger than its storage."""
        data = self.storage.array()
        dtype = floating if data.dtype.kind == "f" else data.dtype
        if 0 in self.shape:
            return np.zeros(self.shape, dtype=dtype)
        view = np.lib.stride_tricks.as_strided(data[self.offset:], shape=self.shape,
                                               strides=[s * data.itemsize for s in self.stride], writeable=False)
        return np.array(view, dtype=dtype)


def _ints(value, what):
    if not isinstance(value, tuple) or not all(type(v) is int for v in value):
        raise CheckpointError(f"_rebuild_tensor_v2: {what} is {describe(value)}, not a tuple of ints")
    if len(value) > 64 or any(not 0 <= v <= MAX_DIMENSION for v in value):
        raise CheckpointError(f"_rebuild_tensor_v2: {what} {clip(value, 120)} has a negative entry or one beyond "
                              f"2^40 (or more than 64 dimensions)")
    return value


def check_view(storage, offset, size, stride):
    """Refuses a view that is not inside its storage or repeats its elements (a zero stride): a
    tensor read is then at most as large as its storage (module docstring)."""
    where = f"tensor of shape {clip(size, 80)} stride {clip(stride, 80)} offset {offset}"
    numel = int(np.prod(size, dtype=object)) if size else 1
    if offset < 0 or offset > storage.numel:
        raise CheckpointError(f"{where}: the offset is outside its storage of {storage.numel} elements")
    if numel == 0:
        if np.prod([max(n, 1) for n in size], dtype=object) > MAX_DIMENSION:
            raise CheckpointError(f"{where}: an empty tensor whose other sizes multiply past 2^40")
        return
    if any(n > 1 and s == 0 for n, s in zip(size, stride)):
        raise CheckpointError(f"{where} repeats its storage's elements through a zero stride: refused (a "
                              "saved parameter is contiguous)")
    last = offset + sum((n - 1) * s for n, s in zip(size, stride))
    if numel > storage.numel or last >= storage.numel:
        raise CheckpointError(f"{where} ({numel} elements) reaches past its storage '{clip(storage.member)}' of "
                              f"{storage.numel} elements")


def rebuild_tensor_v2(storage, storage_offset, size, stride, requires_grad=False, backward_hooks=None,
                      metadata=None):
    if not isinstance(storage, LazyStorage) or type(storage_offset) is not int:
        raise CheckpointError("_rebuild_tensor_v2: its storage is no archive storage")
    size, stride = _ints(size, "size"), _ints(stride, "stride")
    if len(size) != len(stride):
        raise CheckpointError(f"_rebuild_tensor_v2: size {clip(size, 80)} and stride {clip(stride, 80)} differ in "
                              "length")
    check_view(storage, storage_offset, size, stride)
    return LazyTensor(storage, storage_offset, size, stride)


def rebuild_parameter(data, requires_grad=False, backward_hooks=None, state=None):
    if not isinstance(data, LazyTensor):
        raise CheckpointError("_rebuild_parameter: its data is no tensor")
    return data


ALLOWED = {("torch._utils", "_rebuild_tensor_v2"): rebuild_tensor_v2,
           ("torch._utils", "_rebuild_parameter"): rebuild_parameter,
           ("torch._utils", "_rebuild_parameter_with_state"): rebuild_parameter,
           ("collections", "OrderedDict"): collections.OrderedDict}
ALLOWED.update({("torch", name): StorageTag(name, dtype) for name, dtype in STORAGE_DTYPES.items()})


class RestrictedUnpickler(pickle.Unpickler):
    def __init__(self, data, archive):
        super().__init__(io.BytesIO(data))
        self.archive, self.storages = archive, {}

    def find_class(self, module, name):
        found = ALLOWED.get((module, name))
        if found is None:
            raise CheckpointError(f"the pickle references {clip(module, 100)}.{clip(name, 100)}, which is not on "
                                  "the allow-list (torch tensor rebuilders, storage tags, collections.OrderedDict): "
                                  "refused, nothing was run")
        return found

    def persistent_load(self, pid):
        if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage" and
                isinstance(pid[1], StorageTag) and isinstance(pid[2], str) and type(pid[4]) is int and
                0 <= pid[4] <= MAX_DIMENSION):
            raise CheckpointError(f"unknown persistent id ({describe(pid)}; expected ('storage', torch.<T>Storage, "
                                  "key, location, numel))")
        # one storage a key, read once however many tensors view it (as torch.load's loaded_storages)
        storage = self.storages.setdefault(pid[2], LazyStorage(self.archive, f"{self.archive.prefix}data/{pid[2]}",
                                                               pid[1].dtype, pid[4]))
        if (storage.dtype, storage.numel) != (pid[1].dtype, pid[4]):
            raise CheckpointError(f"storage '{clip(pid[2])}' is named twice with different types or sizes")
        return storage


def open_regular(path):
    """The input as a binary file, refused by name unless it is a regular file (stat first, then
    opened non-blocking and checked again on the open file: a FIFO swapped in between neither
    blocks the open nor gets read)."""
    safefiles.require_regular(path)  # safefiles.FileRefused, naming the file
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise CheckpointError("is not a regular file (replaced while being opened): refusing to read it")
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


class Archive:
    """A torch zip archive, read within the bounds of the module docstring."""

    def __init__(self, f):
        self.file = f
        head = f.read(4)
        if head[:1] == b"\x80":
            raise CheckpointError("the legacy torch.save format (torch < 1.6, or _use_new_zipfile_serialization="
                                  "False) is not supported: load and save it again with torch >= 1.6")
        size = os.fstat(f.fileno()).st_size
        self.budget = INFLATION_BUDGET * size + (1 << 20)
        try:
            f.seek(0)
            self.zip = zipfile.ZipFile(f)
            names = self.zip.namelist()
        except Exception as e:  # anything zipfile raises on a damaged directory is the file's fault
            raise CheckpointError(f"not a complete torch zip archive (truncated or damaged?): "
                                  f"{type(e).__name__}: {clip(e)}") from None
        pickles = [n for n in names if n.endswith("/data.pkl") and n.count("/") == 1]
        if len(pickles) != 1:
            raise CheckpointError(f"not a torch checkpoint: expected one <name>/data.pkl, found {len(pickles)}")
        self.prefix = pickles[0][:-len("data.pkl")]
        self.order = "<"
        if self.prefix + "byteorder" in names:
            order = self.read_member(self.prefix + "byteorder", None, 16).decode(errors="replace").strip()
            if order not in ("little", "big"):
                raise CheckpointError(f"byteorder '{clip(order, 20)}' is neither little nor big")
            self.order = "<" if order == "little" else ">"

    def read_member(self, name, want, cap=None):
        """Member name's bytes: its declared size must be want (None: any up to cap), within what is
        left of the budget, checked before anything is inflated; zipfile stops at the declared size
        and checks the CRC."""
        try:
            info = self.zip.getinfo(name)
        except KeyError:
            raise CheckpointError(f"member '{clip(name)}' is missing (truncated archive?)") from None
        if want is not None and info.file_size != want:
            raise CheckpointError(f"member '{clip(name)}' declares {info.file_size} bytes, the pickle says {want} "
                                  "(truncated or damaged archive?)")
        if cap is not None and info.file_size > cap:
            raise CheckpointError(f"member '{clip(name)}' declares {info.file_size} bytes, more than the {cap} "
                                  "allowed")
        if info.file_size > self.budget:
            raise CheckpointError(f"member '{clip(name)}' declares {info.file_size} bytes: with what was read "
                                  f"before, more than {INFLATION_BUDGET} times the archive's size (a compressed "
                                  "member inflating far beyond its archive: torch.save stores them uncompressed)")
        self.budget -= info.file_size
        try:
            data = self.zip.read(info)
        except Exception as e:  # BadZipFile, zlib.error, EOFError, NotImplementedError, RuntimeError, ...
            raise CheckpointError(f"member '{clip(name)}' cannot be read (truncated or damaged?): "
                                  f"{type(e).__name__}: {clip(e)}") from None
        if len(data) != info.file_size:
            raise CheckpointError(f"member '{clip(name)}' holds {len(data)} bytes, it declares {info.file_size} "
                                  "(truncated archive?)")
        return data

    def load(self):
        data = self.read_member(self.prefix + "data.pkl", None, MAX_PICKLE_BYTES)
        try:
            return RestrictedUnpickler(data, self).load()
        except CheckpointError:
            raise
        except Exception as e:  # a malformed pickle: anything the unpickler raises is the file's fault
            raise CheckpointError(f"data.pkl is not a valid pickle: {type(e).__name__}: {clip(e)}") from None


def load(path):
    """The checkpoint's top-level object (tensors as LazyTensor) and its open Archive."""
    f = open_regular(path)
    try:
        archive = Archive(f)
        return archive.load(), archive
    except BaseException:
        f.close()
        raise
