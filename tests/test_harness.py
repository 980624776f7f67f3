"""The C harness itself: every TEST() in tests/*.c is registered (a fixed
table once dropped tests past 512 without a word), and a name filter that
matches nothing fails instead of reporting '0 passed, 0 failed' with exit 0."""
import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
UNIT_TESTS = os.environ.get("UNIT_TESTS")

pytestmark = pytest.mark.skipif(not UNIT_TESTS, reason="UNIT_TESTS not set (make test sets it)")


def test_every_test_in_the_sources_is_registered():
    # the independent count: TEST(name) definitions read from the source files
    declared = set()
    for path in ROOT.glob("tests/test_*.c"):
        declared |= set(re.findall(r"^TEST\((\w+)\)", path.read_text(), re.M))
    listed = subprocess.run([UNIT_TESTS, "--list"], capture_output=True, text=True, check=True).stdout.split()
    assert len(declared) > 100
    assert sorted(listed) == sorted(declared)


def test_a_filter_matching_nothing_fails():
    r = subprocess.run([UNIT_TESTS, "no_test_is_called_this"], capture_output=True, text=True)
    assert r.returncode != 0
    assert "no test matches" in r.stderr
