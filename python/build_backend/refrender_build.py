"""The refrender package's PEP 517 build backend, standard library only:
`pip install --no-build-isolation --no-deps python/` needs no setuptools
and no network (a fresh venv has neither). It writes the wheel itself
(PEP 427: the package's files, librefrender.so beside them, and a
.dist-info with METADATA, WHEEL and RECORD); the version is the C's
RR_VERSION (src/core/common.h), the library the build's: REFRENDER_LIB if
set, else ../build/librefrender.so (`make python`)."""
import base64
import hashlib
import os
import re
import sysconfig
import zipfile

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # python/
ROOT = os.path.dirname(HERE)
NAME = "refrender"


def _version():
    with open(os.path.join(ROOT, "src", "core", "common.h"), encoding="utf-8") as f:
        match = re.search(r'#define RR_VERSION "([^"]+)"', f.read())
    if not match:
        raise RuntimeError("refrender: no RR_VERSION in src/core/common.h")
    return match.group(1)


def _library():
    path = os.environ.get("REFRENDER_LIB") or os.path.join(ROOT, "build", "librefrender.so")
    if not os.path.isfile(path):
        raise RuntimeError(f"refrender: no library at {path}: run `make python` in {ROOT} first (or set "
                           f"REFRENDER_LIB to a built librefrender.so)")
    return path


def _metadata(version):
    return (f"Metadata-Version: 2.1\nName: {NAME}\nVersion: {version}\nSummary: Ground-truth motion-blurred images "
            f"of point-based and Gaussian-splat scenes, as numpy arrays\nRequires-Python: >=3.9\n"
            f"Requires-Dist: numpy\n")


def _tag():
    """py3-none-<platform>: pure Python calling a native library built here."""
    return "py3-none-" + sysconfig.get_platform().replace("-", "_").replace(".", "_")


def _record_line(arcname, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{arcname},sha256={digest},{len(data)}"


def _files(version):
    """(name in the wheel, bytes) of every file but RECORD."""
    package = os.path.join(HERE, NAME)
    files = []
    for entry in sorted(os.listdir(package)):
        if entry.endswith(".py"):
            with open(os.path.join(package, entry), "rb") as f:
                files.append((f"{NAME}/{entry}", f.read()))
    with open(_library(), "rb") as f:
        files.append((f"{NAME}/librefrender.so", f.read()))
    info = f"{NAME}-{version}.dist-info"
    wheel = f"Wheel-Version: 1.0\nGenerator: refrender_build\nRoot-Is-Purelib: false\nTag: {_tag()}\n"
    return files + [(f"{info}/METADATA", _metadata(version).encode()), (f"{info}/WHEEL", wheel.encode())]


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    version = _version()
    name = f"{NAME}-{version}-{_tag()}.whl"
    files = _files(version)
    record = f"{NAME}-{version}.dist-info/RECORD"
    lines = [_record_line(a, d) for a, d in files] + [f"{record},,"]
    tmp = os.path.join(wheel_directory, name + ".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for arcname, data in files:
            info = zipfile.ZipInfo(arcname, date_time=(1980, 1, 1, 0, 0, 0))
            info.external_attr = (0o755 if arcname.endswith(".so") else 0o644) << 16
            z.writestr(info, data, zipfile.ZIP_DEFLATED)
        z.writestr(zipfile.ZipInfo(record, date_time=(1980, 1, 1, 0, 0, 0)), "\n".join(lines) + "\n")
    os.replace(tmp, os.path.join(wheel_directory, name))  # whole or absent
    return name


def get_requires_for_build_wheel(config_settings=None):
    return []
