#!/usr/bin/python3
"""Writes scenes/examples/stg_lite.ply: a small SpacetimeGaussians "lite"
model (Li et al., CVPR 2024; oppo-us-research/SpacetimeGaussians at
427abfc5) in the layout its save_ply writes, for scenes/examples/stg_lite.xml.

Two blobs of 24 Gaussians each cross at the segment's middle (t = 0.5,
frame 25 of the 50-frame segment): an orange one left to right at 8 units
a unit of model time, a blue one right to left and falling (an
acceleration term), each Gaussian turning (omega) and fading in and out
around its own time (trbf_center within 0.05 of 0.5, temporal scale
0.25). Over the example's half-frame exposure (0.01) a blob moves 0.08:
a few pixels at 128x128.

The file (scene/ourslite.py save_ply, 427abfc5:
thirdparty/gaussian_splatting/scene/ourslite.py:335-387): one binary little
endian `vertex` element of 32 float properties, x y z trbf_center
trbf_scale nx ny nz motion_0..8 f_dc_0..2 opacity scale_0..2 rot_0..3
omega_0..3, the raw parameters (scale, trbf_scale as logs, opacity as a
logit, f_dc the colour itself, rot w first). 48 Gaussians keep it under
the 8 KB each committed example may take (tests/test_examples.py).

usage: make_stg_example.py [--out PATH]   (default scenes/examples/stg_lite.ply)"""
import argparse
import pathlib

from pydeps import require  # (a script's own folder is on sys.path already)

require("numpy")
import numpy as np  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
PROPERTIES = (["x", "y", "z", "trbf_center", "trbf_scale", "nx", "ny", "nz"] + [f"motion_{i}" for i in range(9)]
              + [f"f_dc_{i}" for i in range(3)] + ["opacity"] + [f"scale_{i}" for i in range(3)]
              + [f"rot_{i}" for i in range(4)] + [f"omega_{i}" for i in range(4)])
PER_BLOB = 24
MID = 0.5  # the crossing: frame 25 of the segment


def blob(rng, colour, velocity, acceleration):
    """PER_BLOB Gaussians within 0.25 of the origin at t = MID, moving as one, as rows of PROPERTIES."""
    n = PER_BLOB
    at_mid = rng.normal(0.0, 0.12, (n, 3))
    centre = MID + rng.uniform(-0.05, 0.05, n)
    D = MID - centre                      # where each one is at MID: its cubic from its own centre
    motion = np.zeros((n, 9))
    motion[:, 0:3] = velocity
    motion[:, 3:6] = acceleration
    xyz = at_mid - motion[:, 0:3] * D[:, None] - motion[:, 3:6] * (D * D)[:, None]
    rows = np.zeros((n, len(PROPERTIES)))
    rows[:, 0:3] = xyz
    rows[:, 3] = centre
    rows[:, 4] = np.log(0.25)             # temporal scale exp(trbf_scale)
    rows[:, 8:17] = motion
    rows[:, 17:20] = np.clip(colour + rng.normal(0.0, 0.05, (n, 3)), 0.0, 1.0)
    rows[:, 20] = np.log(0.8 / 0.2)       # sigmoid -> 0.8
    rows[:, 21:24] = np.log(np.stack([np.full(n, 0.09), np.full(n, 0.04), np.full(n, 0.03)], axis=1))
    rows[:, 24:28] = rng.normal(0.0, 1.0, (n, 4))
    rows[:, 28:32] = rng.normal(0.0, 3.0, (n, 4))
    return rows


def model():
    rng = np.random.default_rng(2024)
    orange = blob(rng, np.array([1.0, 0.5, 0.1]), (8.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    blue = blob(rng, np.array([0.2, 0.5, 1.0]), (-8.0, 1.0, 0.0), (0.0, -6.0, 0.0))
    return np.concatenate([orange, blue]).astype("<f4")


def write(path, rows):
    head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % len(rows)
    head += "".join(f"property float {p}\n" for p in PROPERTIES) + "end_header\n"
    path.write_bytes(head.encode("ascii") + rows.tobytes())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "scenes" / "examples" / "stg_lite.ply",
                    help="where to write the PLY (default scenes/examples/stg_lite.ply)")
    args = ap.parse_args()
    write(args.out, model())


if __name__ == "__main__":
    main()
