#!/usr/bin/python3
"""compare.py: the command line of refrender.comparison (python/refrender/comparison.py, whose
docstring and --help are its manual), run from a clone with /usr/bin/python3, nothing installed."""
import os
import sys

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES, "matplotlib")  # a missing package: one line, not a traceback

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "python"))
from refrender.comparison import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
