#!/usr/bin/python3
"""False-failure rate of the regression check: renders SCENE fast (as
tests/test_regression.py does) with N different seeds and counts how many
renders regress.py calls inconsistent with the reference.

usage: regress_seeds.py SCENE_NAME [N] [--eps X]   (from the repository root)
"""
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import regress  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    name, n = argv[1], int(argv[2]) if len(argv) > 2 and not argv[2].startswith("-") else 50
    extra = argv[argv.index("--eps"):argv.index("--eps") + 2] if "--eps" in argv else []
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
    sys.exit(main(sys.argv))
