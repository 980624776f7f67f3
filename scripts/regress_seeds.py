#!/usr/bin/python3
"""False-failure rate of the regression check: renders SCENE fast (as
tests/test_regression.py does) with N different seeds and counts how many
renders regress.py calls inconsistent with the reference.

usage: regress_seeds.py SCENE_NAME [N] [--eps X]
"""
import argparse
import os
import subprocess
import sys
import tempfile

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES)  # a missing package: one line, not a traceback

import regress

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", metavar="SCENE_NAME", help="a suite scene: scenes/NAME.xml with reference_images/NAME.exr")
    p.add_argument("n", metavar="N", type=int, nargs="?", default=50, help="number of seeds (default 50)")
    p.add_argument("--eps", metavar="X", help="render with this epsilon (a planted blending bug)")
    args = p.parse_args(argv)
    name, n = args.scene, args.n
    extra = ["--eps", args.eps] if args.eps is not None else []
    binary = os.environ.get("REFRENDER", os.path.join(ROOT, "build", "refrender"))
    ref = os.path.join(ROOT, "reference_images", f"{name}.exr")
    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(1000, 1000 + n):
            out = os.path.join(tmp, "t.exr")
            subprocess.run([binary, os.path.join(ROOT, "scenes", f"{name}.xml"), "--spp", "4", "--tspp", "4",
                            "--batches", "8", "--seed", str(seed), "--quiet", *extra, "-o", out], check=True)
            r = regress.check(ref, out)
            failures += not r["ok"]
            if not r["ok"]:
                print(f"seed {seed}: {r}")
    print(f"{name}: {failures} of {n} seeds inconsistent ({failures / n:.0%})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
