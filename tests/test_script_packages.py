"""The scripts say what they need: run under an interpreter that cannot
import their packages (another python3 first on PATH: pyenv, conda, a
virtual environment), each tool ends with one line naming the missing
modules, their Debian packages and what to do (/usr/bin/python3 after
scripts/install-deps.sh), exit status 2, and no traceback.

Two ways to take packages away, neither depending on what else the machine
has installed: `python3 -S` (no site directories, so none of Debian's
dist-packages: every package is missing), and a directory first on
PYTHONPATH holding a sitecustomize that puts a finder first in
sys.meta_path which refuses `OpenImageIO` as a missing module is refused
(only that module missing; a package of that name raising on import would
not do: the scripts look modules up without importing them).
With the packages, every tool answers --help (tests/test_docs.py)."""
import os
import subprocess

import pytest

from conftest import ROOT

TOOLS = ["compare.py", "convergence.py", "convert_4dgs.py", "cost_error.py", "dataset.py", "gallery.py", "regress.py",
         "regress_seeds.py", "time_to_error.py"]
ADVICE = "run with /usr/bin/python3 after scripts/install-deps.sh"


def run_tool(script, *python_args, env=None):
    return subprocess.run(["/usr/bin/python3", *python_args, str(ROOT / "scripts" / script), "--help"],
                          capture_output=True, text=True, env=env, timeout=60)


@pytest.mark.parametrize("script", TOOLS)
def test_without_site_packages_the_tool_says_what_to_do(script):
    proc = run_tool(script, "-S")
    lines = proc.stderr.splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and proc.stdout == "", (proc.stdout, proc.stderr)
    assert lines[0].startswith(f"{script}: ") and "numpy (python3-numpy)" in lines[0] and ADVICE in lines[0]


def test_one_missing_module_is_named_alone(tmp_path):
    (tmp_path / "sitecustomize.py").write_text(
        "import sys\n"
        "class HideOpenImageIO:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'OpenImageIO':\n"
        "            raise ModuleNotFoundError(f'No module named {name!r} (test shim)', name=name)\n"
        "sys.meta_path.insert(0, HideOpenImageIO())\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    proc = run_tool("compare.py", env=env)
    lines = proc.stderr.splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert "OpenImageIO (python3-openimageio)" in lines[0] and "numpy" not in lines[0] and ADVICE in lines[0]

