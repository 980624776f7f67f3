#!/usr/bin/python3
"""Contact sheet of rendered scenes: each EXR tone-mapped like refrender's
preview (RGB clamped to [0, 1], sRGB transfer curve), labelled with its file
name when a font is available, four to a row in the order given.

usage: gallery.py OUT.png IMAGE.exr [IMAGE.exr ...]
"""
import argparse
import os
import sys

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES)  # a missing package: one line, not a traceback

import numpy as np
import OpenImageIO as oiio

import flip
import imagecompare

COLUMNS, LABEL = 4, 18


def tile(path):
    img = imagecompare.read_image(path, "linear")
    rgb = imagecompare.composite(img, (0, 0, 0))
    srgb = flip.linear_to_srgb(np.clip(rgb, 0, 1))
    h, w, _ = srgb.shape
    out = np.zeros((h + LABEL, w, 3), dtype=np.float32)
    out[LABEL:] = srgb
    buf = oiio.ImageBuf(out)
    name = os.path.splitext(os.path.basename(path))[0]
    if not oiio.ImageBufAlgo.render_text(buf, 4, LABEL - 4, name, 13, "", (0.9, 0.9, 0.9)):
        return srgb  # no font on this machine: no label band
    return buf.get_pixels(oiio.FLOAT)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", metavar="OUT.png", help="contact sheet to write (8-bit, format by extension)")
    p.add_argument("images", metavar="IMAGE", nargs="+", help="images to show, in this order")
    args = p.parse_args(argv)
    tiles = [tile(path) for path in args.images]
    h = max(t.shape[0] for t in tiles)
    w = max(t.shape[1] for t in tiles)
    rows = (len(tiles) + COLUMNS - 1) // COLUMNS
    sheet = np.zeros((rows * h, min(len(tiles), COLUMNS) * w, 3), dtype=np.float32)
    for i, t in enumerate(tiles):
        y, x = (i // COLUMNS) * h, (i % COLUMNS) * w
        sheet[y:y + t.shape[0], x:x + t.shape[1]] = t
    buf = oiio.ImageBuf(sheet)
    if not buf.write(args.out, "uint8"):
        print(f"gallery.py: {args.out}: {buf.geterror()}", file=sys.stderr)
        return 1
    print(f"gallery.py: {len(tiles)} images -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
