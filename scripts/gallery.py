#!/usr/bin/python3
"""Contact sheet of rendered scenes: each image's RGB as stored (a
refrender EXR's RGB already holds the scene's own background where nothing
is covered) shown like refrender's preview (clamped to [0, 1]; linear light
encoded with the sRGB curve, display-encoded values such as a Gaussian
model's as they are: each file's encoding as compare.py reads it, an assumed
one said on stderr), labelled with its file name, four to a row in the order
given.

usage: gallery.py OUT.png IMAGE.exr [IMAGE.exr ...] [--font FONT]

Labels are drawn with matplotlib's own DejaVu Sans (a file every machine
with the scripts' packages has, so sheets made on two machines agree), else
OpenImageIO's search for DejaVuSans or its default font; when none can be
drawn the sheet is written without labels and stderr says so.
"""
import argparse
import os
import sys

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES, "matplotlib")  # a missing package: one line, not a traceback

import numpy as np
import OpenImageIO as oiio

import flip
import imagecompare
import safefiles

COLUMNS, LABEL = 4, 18
# float formats: a contact sheet is 8-bit, so OUT with one of these is an input image named first by mistake
FLOAT_EXTENSIONS = (".exr", ".hdr", ".pfm")


def font_candidates(requested):
    """--font alone when given; else matplotlib's bundled DejaVu Sans file,
    then OpenImageIO's search for DejaVuSans, then its default ("": Droid
    Sans, which Debian does not ship)."""
    if requested:
        return [requested]
    import matplotlib
    bundled = os.path.join(matplotlib.get_data_path(), "fonts", "ttf", "DejaVuSans.ttf")
    return [bundled, "DejaVuSans", ""]


def label_font(requested):
    """The first candidate font OpenImageIO can draw with, or None."""
    for font in font_candidates(requested):
        probe = oiio.ImageBuf(np.zeros((LABEL, 16, 3), dtype=np.float32))
        if oiio.ImageBufAlgo.render_text(probe, 2, LABEL - 4, "x", 13, font, (1, 1, 1)):
            return font
    return None


def tile(path, font):
    """One image as it would be displayed, with its name above it when a
    font is available. Its RGB is used as stored: a refrender image's RGB
    already holds the scene's background (weighted by 1 - coverage), which
    the committed gallery shows; compositing over black would hide it."""
    img = imagecompare.read_image(path)
    if not img.encoding.known:
        print(f"gallery.py: {path}: colour encoding not stated, {img.encoding}", file=sys.stderr)
    srgb = flip.linear_to_srgb(img.rgb).astype(np.float32)  # decoded as stated, then clamped and encoded
    if font is None:
        return srgb
    h, w, _ = srgb.shape
    out = np.zeros((h + LABEL, w, 3), dtype=np.float32)
    out[LABEL:] = srgb
    buf = oiio.ImageBuf(out)
    name = os.path.splitext(os.path.basename(path))[0]
    oiio.ImageBufAlgo.render_text(buf, 4, LABEL - 4, name, 13, font, (0.9, 0.9, 0.9))
    return buf.get_pixels(oiio.FLOAT)


def check_arguments(args):
    """Refuses, before anything is read or drawn, an OUT that is one of the
    images or has a float image's extension (`gallery.py a.exr b.exr` with
    OUT forgotten), and inputs that are not regular files."""
    if os.path.splitext(args.out)[1].lower() in FLOAT_EXTENSIONS:
        raise safefiles.FileRefused(f"{args.out}: OUT is an 8-bit contact sheet (e.g. sheet.png), not a float image: "
                                    "was OUT left out? usage: gallery.py OUT.png IMAGE [IMAGE ...]")
    for path in args.images:
        safefiles.require_regular(path)
    inputs = safefiles.Inputs(args.images)
    inputs.check_output(args.out, "OUT")
    return inputs


def write_sheet(path, sheet, inputs):
    """The sheet as 8-bit, whole or not at all, checked by reading it back."""
    def write(tmp):
        buf = oiio.ImageBuf(sheet)
        if not buf.write(tmp, "uint8"):
            raise OSError(buf.geterror() or "OpenImageIO cannot write it")
    safefiles.write_file(path, write, inputs, imagecompare.check_written)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", metavar="OUT.png", help="contact sheet to write (8-bit, format by extension)")
    p.add_argument("images", metavar="IMAGE", nargs="+", help="images to show, in this order")
    p.add_argument("--font", help="font for the labels: a name OpenImageIO finds or a .ttf file (default: "
                                  "matplotlib's DejaVu Sans, else OpenImageIO's DejaVuSans or default font)")
    args = p.parse_args(argv)
    try:
        inputs = check_arguments(args)
        return draw(args, inputs)
    except (safefiles.FileRefused, imagecompare.CompareError) as e:
        print(f"gallery.py: {e}", file=sys.stderr)
        return 1


def draw(args, inputs):
    font = label_font(args.font)
    if font is None:
        tried = ", ".join(repr(f) for f in font_candidates(args.font))
        print(f"gallery.py: OpenImageIO cannot draw with any font tried ({tried}): the sheet has no labels; "
              "give --font FILE.ttf", file=sys.stderr)
    tiles = [tile(path, font) for path in args.images]
    h = max(t.shape[0] for t in tiles)
    w = max(t.shape[1] for t in tiles)
    rows = (len(tiles) + COLUMNS - 1) // COLUMNS
    sheet = np.zeros((rows * h, min(len(tiles), COLUMNS) * w, 3), dtype=np.float32)
    for i, t in enumerate(tiles):
        y, x = (i // COLUMNS) * h, (i % COLUMNS) * w
        sheet[y:y + t.shape[0], x:x + t.shape[1]] = t
    write_sheet(args.out, sheet, inputs)
    print(f"gallery.py: {len(tiles)} images -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
