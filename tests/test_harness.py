"""The C harness itself: every TEST() in tests/*.c is registered (a fixed
table once dropped tests past 512 without a word), and a name filter that
matches nothing fails instead of reporting '0 passed, 0 failed' with exit 0."""
import os
import subprocess

import pytest

from conftest import c_tests_by_file
UNIT_TESTS = os.environ.get("UNIT_TESTS")

pytestmark = pytest.mark.skipif(not UNIT_TESTS, reason="UNIT_TESTS not set (make test sets it)")


def test_every_test_in_the_sources_is_registered():
    # the independent count: TEST(name) definitions read from the source files
    declared = {name for names in c_tests_by_file().values() for name in names}
    listed = subprocess.run([UNIT_TESTS, "--list"], capture_output=True, text=True, check=True).stdout.split()
    assert len(declared) > 100
    assert sorted(listed) == sorted(declared)


def test_a_filter_matching_nothing_fails():
    r = subprocess.run([UNIT_TESTS, "no_test_is_called_this"], capture_output=True, text=True)
    assert r.returncode != 0
    assert "no test matches" in r.stderr
