"""Figure-ready outputs for compare.py: error maps at the images' native
resolution (PNG, optionally upscaled by an integer with nearest neighbour,
and float EXR), crop windows drawn on the full image with zoomed insets,
and a booktabs LaTeX table with the best value of each column in bold.

Colour maps are applied by lookup, never by resampling a plotted figure, so
one map pixel is one image pixel. Every method's maps share one range
(compare.py passes it), so their colours compare across methods."""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import OpenImageIO as oiio  # noqa: E402

from . import flip, imagecompare, safefiles  # noqa: E402
from .heatmaps import _name  # noqa: E402

# per column: True when a higher value is better
HIGHER_IS_BETTER = {"PSNR": True, "SSIM": True}


def _write(path, pixels, fmt, inputs):
    """One picture, whole or not at all (safefiles), checked by reading it back."""
    pixels = np.ascontiguousarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt)

    def write(tmp):
        out = oiio.ImageOutput.create(tmp)
        ok = bool(out) and out.open(tmp, spec) and out.write_image(pixels)
        if out:
            ok = out.close() and ok
        if not ok:
            raise OSError(oiio.geterror() or "OpenImageIO cannot write it")
    safefiles.write_file(path, write, inputs, imagecompare.check_written)


def _upscale(img, scale):
    return np.repeat(np.repeat(img, scale, axis=0), scale, axis=1) if scale > 1 else img


def colorize(values, cmap, lo, hi):
    """8-bit RGB of values through a matplotlib colour map over [lo, hi];
    NaN as 0, and values beyond the range (an infinite one too) at its ends:
    clipped before the subtraction, which overflowed for +-inf (nan_to_num's
    +-1.8e308) less a lo of the other sign."""
    span = hi - lo if hi > lo else 1.0
    norm = (np.clip(np.nan_to_num(values), lo, lo + span) - lo) / span
    return (plt.get_cmap(cmap)(norm)[..., :3] * 255 + 0.5).astype(np.uint8)


def write_map(out_dir, base, values, cmap, lo, hi, scale, inputs=None):
    """base.png (coloured, native resolution x scale) and base.exr (the float values)."""
    _write(os.path.join(out_dir, base + ".png"), _upscale(colorize(values, cmap, lo, hi), scale), oiio.UINT8, inputs)
    _write(os.path.join(out_dir, base + ".exr"), values.astype(np.float32), oiio.FLOAT, inputs)
    return [base + ".png", base + ".exr"]


def srgb8(rgb):
    return (flip.linear_to_srgb(np.nan_to_num(rgb)) * 255 + 0.5).astype(np.uint8)


def draw_rectangles(img, windows, color=(255, 64, 32)):
    """The crop windows outlined (one pixel wide, inside the window) on an 8-bit image."""
    out = img.copy()
    for x, y, w, h in windows:
        out[y, x:x + w] = color
        out[y + h - 1, x:x + w] = color
        out[y:y + h, x] = color
        out[y:y + h, x + w - 1] = color
    return out


def write_crops(out_dir, label, test, crops, inset_scale, inputs=None):
    """label_crops.png: the test image with every crop outlined; one zoomed
    inset per crop."""
    files = []
    full = srgb8(test)
    name = _name(label, "crops") + ".png"
    _write(os.path.join(out_dir, name), draw_rectangles(full, [w for _, w in crops]), oiio.UINT8, inputs)
    files.append(name)
    for crop, (x, y, w, h) in crops:
        inset = _name(label, crop) + "_inset.png"
        _write(os.path.join(out_dir, inset), _upscale(full[y:y + h, x:x + w], inset_scale), oiio.UINT8, inputs)
        files.append(inset)
    return files


def comparison_group(row):
    """The rows a value competes with for bold: the same frame (or the same
    summary, mean or worst) and the same window. A bold value across frames or
    windows would compare a crop's error with a full image's, or frame 3's
    with frame 0's, which says nothing about the methods."""
    frame = row.get("frame")
    if isinstance(frame, str) and frame.startswith("worst"):
        frame = "worst"
    return frame, row.get("window")


def best_values(rows, columns):
    """Per comparison group and column, the best value among the rows of that
    group (lowest error; highest PSNR and SSIM); columns without a numeric
    value are left out."""
    best = {}
    for r in rows:
        group = best.setdefault(comparison_group(r), {})
        for c in columns:
            v = r.get(c)
            if isinstance(v, (int, float)) and (c not in group or
                                                (v > group[c] if HIGHER_IS_BETTER.get(c) else v < group[c])):
                group[c] = v
    return best


def _tex(text):
    for a, b in [("\\", r"\textbackslash{}"), ("_", r"\_"), ("%", r"\%"), ("&", r"\&"), ("#", r"\#"),
                 ("$", r"\$"), (">", r"$>$")]:
        text = text.replace(a, b)
    return text


def _latex_cell(value, best):
    if not isinstance(value, (int, float)):
        return "--"
    text = "$\\infty$" if isinstance(value, float) and np.isinf(value) else f"{value:.4g}"
    return r"\textbf{" + text + "}" if best == value else text


def latex_table(rows, columns, path, inputs=None):
    """A booktabs table: one row per input row (method, frame when the rows
    come from a sequence, window), the best value of each column in bold
    among the rows of the same frame (or summary) and window. Rows come in
    groups (a frame, the means, the worst frames), a rule between groups."""
    best = best_values(rows, columns)
    frames = any(r.get("frame") is not None for r in rows)
    names = ["Method"] + (["Frame"] if frames else []) + ["Window"]
    lines = [r"\begin{tabular}{" + "l" * len(names) + "r" * len(columns) + "}", r"\toprule",
             " & ".join(names + [_tex(c) for c in columns]) + r" \\", r"\midrule"]
    previous = None
    for r in rows:
        group = comparison_group(r)[0]
        if previous is not None and group != previous:
            lines.append(r"\midrule")
        previous = group
        head = [str(r["image"])] + ([str(r.get("frame", ""))] if frames else []) + [str(r["window"])]
        cells = [_latex_cell(r.get(c), best[comparison_group(r)].get(c)) for c in columns]
        lines.append(" & ".join([_tex(h) for h in head] + cells) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}"]
    safefiles.write_text(path, "% refrender compare.py; requires \\usepackage{booktabs}\n" + "\n".join(lines) + "\n",
                         inputs)
