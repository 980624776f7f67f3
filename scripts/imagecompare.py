"""This module is refrender.imagecompare (python/refrender/imagecompare.py), the Python package's, under
its old name: the scripts (and others' code) import it from a clone with /usr/bin/python3, nothing installed."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "python"))
import refrender.imagecompare  # noqa: E402

sys.modules[__name__] = refrender.imagecompare
