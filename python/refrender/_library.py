"""librefrender.so through ctypes: finding it and declaring its functions
(src/api/refrender_api.h is the C side of every declaration here)."""
import ctypes
import os

_LIB_NAME = "librefrender.so"


class LibraryMissing(ImportError):
    """librefrender.so is neither where REFRENDER_LIB says nor beside the
    package (a wheel built without it, or a build since removed)."""


def library_path():
    """REFRENDER_LIB if set (a build tree's library, say), else the copy the
    wheel installed beside this module."""
    return os.environ.get("REFRENDER_LIB") or os.path.join(os.path.dirname(os.path.abspath(__file__)), _LIB_NAME)


def _declare(lib):
    c_int, c_char_p, c_void_p = ctypes.c_int, ctypes.c_char_p, ctypes.c_void_p
    signatures = {
        "refrender_render": (c_int, [c_int, ctypes.POINTER(c_char_p), ctypes.POINTER(c_int),
                                     ctypes.POINTER(c_void_p), c_char_p, ctypes.c_size_t]),
        "refrender_result_free": (None, [c_void_p]),
        "refrender_result_window": (None, [c_void_p, ctypes.POINTER(c_int)]),
        "refrender_result_channels": (c_int, [c_void_p]),
        "refrender_result_channel_name": (c_char_p, [c_void_p, c_int]),
        "refrender_result_channel": (ctypes.POINTER(ctypes.c_float), [c_void_p, c_int]),
        "refrender_result_attrs": (c_int, [c_void_p]),
        "refrender_result_attr_key": (c_char_p, [c_void_p, c_int]),
        "refrender_result_attr_text": (c_char_p, [c_void_p, c_int]),
        "refrender_result_attr_type": (c_int, [c_void_p, c_int]),
        "refrender_result_attr_numbers": (c_int, [c_void_p, c_int, ctypes.POINTER(ctypes.c_double)]),
        "refrender_version": (c_char_p, []),
    }
    for name, (restype, argtypes) in signatures.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    return lib


_lib = None


def load():
    """The library, loaded on first use (importing refrender never fails for
    want of it: compare() needs none)."""
    global _lib
    if _lib is None:
        path = library_path()
        if not os.path.exists(path):
            raise LibraryMissing(
                f"refrender: no {_LIB_NAME} at {path}: build it in a refrender clone with `make python` and "
                f"reinstall the package (pip install --no-build-isolation --no-deps python/), or set "
                f"REFRENDER_LIB to a built build/{_LIB_NAME}")
        try:
            _lib = _declare(ctypes.CDLL(path))
        except OSError as e:  # a missing system library (Embree, OpenEXR, ...) or another machine's build
            raise LibraryMissing(f"refrender: cannot load {path}: {e} (scripts/install-deps.sh installs what it "
                                 f"needs; a library built elsewhere may need `make python` here)") from None
    return _lib
