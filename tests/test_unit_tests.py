"""The C unit tests (tests/test_*.c, build-check/unit_tests) and the fuzz
corpora's replays (tests/fuzz/, build-check/replay/replay_NAME), a pytest
item for each C test file and each corpus, so that pytest's workers share
them out beside the Python tests: `make test` ran them one after the other
before pytest, 17 s of a single core. A file's tests run together
(`unit_tests --only NAME...`; an item a test cost 10 s more in starting
processes), their output shown when one fails; `make test-c` and `make
test-fuzz` still run them directly."""
import os
import subprocess
from pathlib import Path

import pytest

from conftest import ROOT, c_tests_by_file

UNIT_TESTS = os.environ.get("UNIT_TESTS")
REPLAY_DIR = os.environ.get("FUZZ_REPLAY_DIR")
C_TESTS = c_tests_by_file()  # (test_harness.py checks every one is registered)


def fuzz_targets():
    return sorted(p.name for p in (ROOT / "tests" / "fuzz" / "corpus").iterdir() if p.is_dir())


@pytest.mark.skipif(not UNIT_TESTS, reason="UNIT_TESTS not set (make test sets it)")
@pytest.mark.parametrize("file", C_TESTS)
def test_c(file):
    names = C_TESTS[file]
    proc = subprocess.run([UNIT_TESTS, "--only", *names], capture_output=True, text=True)
    ran = [line.split()[1].rstrip(":") for line in proc.stdout.splitlines()
           if line.startswith(("ok ", "FAIL ", "SKIP "))]  # (a check's own FAIL lines are indented)
    assert proc.returncode == 0 and sorted(ran) == sorted(names), proc.stdout + proc.stderr


@pytest.mark.skipif(not REPLAY_DIR, reason="FUZZ_REPLAY_DIR not set (make test sets it)")
@pytest.mark.parametrize("target", fuzz_targets())
def test_fuzz_corpus_replays(target):
    corpus = ROOT / "tests" / "fuzz" / "corpus" / target
    proc = subprocess.run([Path(REPLAY_DIR) / f"replay_{target}", corpus], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + "\n".join(proc.stderr.splitlines()[-40:])
    assert f"replayed {sum(1 for p in corpus.iterdir() if p.is_file())} corpus inputs" in proc.stdout
