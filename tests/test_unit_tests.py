"""The C unit tests (tests/test_*.c, build-check/unit_tests) and the fuzz
corpora's replays (tests/fuzz/, build-check/replay/replay_NAME), one pytest
item each, so that pytest's workers share them out beside the Python tests:
`make test` ran them one after the other before pytest, 17 s of a single
core. Each C test runs alone (`unit_tests --only NAME`), its output shown
when it fails; `make test-c` and `make test-fuzz` still run them directly."""
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
UNIT_TESTS = os.environ.get("UNIT_TESTS")
REPLAY_DIR = os.environ.get("FUZZ_REPLAY_DIR")


def unit_test_names():
    if not UNIT_TESTS:
        return []
    return subprocess.run([UNIT_TESTS, "--list"], capture_output=True, text=True, check=True).stdout.split()


def fuzz_targets():
    return sorted(p.name for p in (ROOT / "tests" / "fuzz" / "corpus").iterdir() if p.is_dir())


@pytest.mark.skipif(not UNIT_TESTS, reason="UNIT_TESTS not set (make test sets it)")
@pytest.mark.parametrize("name", unit_test_names())
def test_c(name):
    proc = subprocess.run([UNIT_TESTS, "--only", name], capture_output=True, text=True)
    lines = proc.stdout.splitlines()
    assert proc.returncode == 0 and lines[-1] in ("1 passed, 0 failed", "0 passed, 0 failed, 1 skipped"), \
        proc.stdout + proc.stderr


@pytest.mark.skipif(not REPLAY_DIR, reason="FUZZ_REPLAY_DIR not set (make test sets it)")
@pytest.mark.parametrize("target", fuzz_targets())
def test_fuzz_corpus_replays(target):
    corpus = ROOT / "tests" / "fuzz" / "corpus" / target
    proc = subprocess.run([Path(REPLAY_DIR) / f"replay_{target}", corpus], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + "\n".join(proc.stderr.splitlines()[-40:])
    assert f"replayed {sum(1 for p in corpus.iterdir() if p.is_file())} corpus inputs" in proc.stdout
