"""The Python packages the scripts need, checked before the first use.

The scripts run under Debian 12's /usr/bin/python3 with the Debian packages
scripts/install-deps.sh installs. Another python3 first on PATH (pyenv,
conda, a virtual environment) has none of them, and Python's own
ModuleNotFoundError, raised deep inside an import, says neither which
interpreter to use nor what to install. Each script calls require() before
its other imports: a missing module ends the script with one line saying
what to do, and exit status 2, as every other bad start of a script.
Modules are looked up, not imported: a script imports what it uses when
it uses it (importing all of them here cost every run of compare.py, even
--help and its refusals, 1.2 s of CPU for skimage, matplotlib and
OpenImageIO)."""
import importlib.util
import os
import sys

# import name -> the Debian package scripts/install-deps.sh installs for it
DEBIAN_PACKAGES = {
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "skimage": "python3-skimage",
    "OpenImageIO": "python3-openimageio",
    "matplotlib": "python3-matplotlib",
}

# what scripts/imagecompare.py and scripts/flip.py import: every tool reads images through them
IMAGE_MODULES = ("numpy", "scipy", "skimage", "OpenImageIO")


def missing_modules(names):
    """The names among `names` this interpreter cannot find (its import
    system's finders say where each would load from, without loading it)."""
    missing = []
    for name in names:
        try:
            found = importlib.util.find_spec(name) is not None
        except (ImportError, ValueError):  # a finder's refusal, or a module without a spec
            found = False
        if not found:
            missing.append(name)
    return missing


def require(*names):
    """Returns when every module in `names` is found; otherwise prints one
    line naming the missing ones, their Debian packages and the interpreter
    that lacks them, and exits with status 2."""
    missing = missing_modules(names)
    if not missing:
        return
    script = os.path.basename(sys.argv[0]) or "refrender script"
    listed = ", ".join(f"{name} ({DEBIAN_PACKAGES.get(name, 'a Python package')})" for name in missing)
    sys.stderr.write(f"{script}: {sys.executable} cannot import {listed}: run with /usr/bin/python3 after "
                     f"scripts/install-deps.sh\n")
    sys.exit(2)
