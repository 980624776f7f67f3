"""Error pictures for compare.py: FLIP maps (magma, as in the FLIP paper),
signed difference maps (diverging), contact sheets and an offline HTML report."""
import html
import os
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from . import flip, imagecompare, safefiles


def _name(label, window):
    """A file name from the test's label (unique among the inputs) and the
    window: the label's extension, if any, is dropped."""
    stem = re.sub(r"\.(exr|png|tiff?|jpe?g|hdr)$", "", label, flags=re.IGNORECASE)
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{stem}_{window}").strip("_")


def _save(fig, path, inputs):
    """A figure, whole or not at all (safefiles), checked by reading it back."""
    try:
        safefiles.write_file(path, lambda tmp: fig.savefig(tmp, dpi=100, bbox_inches="tight"), inputs,
                             imagecompare.check_written)
    finally:
        plt.close(fig)


def _save_map(values, cmap, vmin, vmax, title, label, path, inputs=None):
    h, w = values.shape
    fig, ax = plt.subplots(figsize=(max(3.0, 5.0 * w / max(w, h)) + 1.2, max(3.0, 5.0 * h / max(w, h))))
    im = ax.imshow(values, cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest")
    ax.set_title(title, fontsize=9)
    ax.axis("off")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label=label)
    _save(fig, path, inputs)


def _contact_sheet(ref, test, flip_map, title, path, inputs=None):
    fig, axes = plt.subplots(1, 3, figsize=(12, 4.4))
    panels = [(flip.linear_to_srgb(ref), "reference"), (flip.linear_to_srgb(test), "test"),
              (flip_map, "LDR-FLIP error")]
    for ax, (img, name) in zip(axes, panels):
        kw = {"cmap": "magma", "vmin": 0, "vmax": 1} if img.ndim == 2 else {}
        ax.imshow(img, interpolation="nearest", **kw)
        ax.set_title(name, fontsize=9)
        ax.axis("off")
    fig.suptitle(title, fontsize=10)
    _save(fig, path, inputs)


def write_all(maps, out_dir, diff_range, inputs=None):
    """maps: (test label, window name, (x, y, w, h), ref, test, LDR-FLIP map
    and HDR-FLIP map (or None) of the window); difference maps span
    [-diff_range, diff_range], the same for every input. Returns one dict of
    written file names per entry."""
    os.makedirs(out_dir, exist_ok=True)
    written = []
    for path, window, (x, y, w, h), ref, test, flip_map, _ in maps:
        r, t = ref[y:y + h, x:x + w], test[y:y + h, x:x + w]
        r, t = np.where(np.isfinite(r), r, 0), np.where(np.isfinite(t), t, 0)
        base = _name(path, window)
        files = {"flip": f"{base}_flip.png", "diff": f"{base}_diff.png", "sheet": f"{base}_sheet.png"}
        title = f"{path} [{window}]"
        _save_map(flip_map, "magma", 0.0, 1.0, f"LDR-FLIP, {title}", "FLIP", os.path.join(out_dir, files["flip"]),
                  inputs)
        diff = (t - r).mean(axis=-1)
        _save_map(diff, "RdBu_r", -diff_range, diff_range, f"test - reference (mean of RGB), {title}", "signed difference",
                  os.path.join(out_dir, files["diff"]), inputs)
        _contact_sheet(r, t, flip_map, title, os.path.join(out_dir, files["sheet"]), inputs)
        written.append(files)
    return written


LEGEND = {
    "MAE": "mean |test - reference| over valid pixels and RGB",
    "MSE": "mean (test - reference)^2",
    "RMSE": "square root of MSE",
    "PSNR": "10 log10(peak^2 / MSE), peak from --psnr-peak (default 1)",
    "relMSE": "mean (test - reference)^2 / (reference^2 + 0.01)",
    "SSIM": "structural similarity (Wang et al. 2004), Gaussian sigma 1.5, on RGB clamped to [0, --ssim-peak]",
    "FLIP": "mean LDR-FLIP (Andersson et al. 2020), 0 = identical, 1 = most different",
    "FLIP p50w": "error-weighted median of the LDR-FLIP map",
    "FLIP p95w": "error-weighted 95th percentile of the LDR-FLIP map",
    "HDR-FLIP": "mean HDR-FLIP (Andersson et al. 2021); n/a: the reason is in notes, below the table",
    "pixels": "valid pixels compared (finite in both images, inside --mask)",
    "nonfinite": "pixels left out because either image is NaN or infinite there",
    "SE source": "the standard errors >KSE divides by",
    "frame": "the frame of a sequence; 'mean' over frames, 'worst (N)': the frame with the largest RMSE",
    "notes": "why a value is n/a",
}


def _legend(cols):
    items = []
    for c in cols:
        if c.startswith(">") and c.endswith("SE"):
            text = (f"fraction of pixels where some channel differs by more than {c[1:-2]} standard errors of the "
                    "difference: the reference's stderr.* channels, combined with the test's (its stderr.* "
                    "channels or --test-noise) when known, never below --se-floor")
        else:
            text = LEGEND.get(c)
        if text:
            items.append(f"<li><b>{html.escape(c)}</b>: {html.escape(text)}</li>")
    return "<ul>" + "".join(items) + "</ul>"


def write_report(rows, pictures, out_dir, reference, metrics_space="linear", inputs=None):
    cols = [k for k in dict.fromkeys(k for r in rows for k in r) if not k.endswith("note")]
    notes = "".join(f"<p>{html.escape(str(r['image']))} [{html.escape(str(r['window']))}]: "
                    f"{html.escape(r['notes'])}</p>\n" for r in rows if r.get("notes"))
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = ""
    for r in rows:
        cells = "".join(f"<td>{html.escape(_fmt(r.get(c)))}</td>" for c in cols)
        body += f"<tr>{cells}</tr>\n"
    figures = ""
    for r, files in zip(rows, pictures):
        frame = f", frame {r['frame']}" if "frame" in r else ""
        figures += f"<h3>{html.escape(str(r['image']))}{html.escape(frame)} [{html.escape(r['window'])}]</h3>\n"
        figures += "".join(f'<img src="{html.escape(f)}" alt="{k}">\n' for k, f in files.items())
    page = f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>refrender comparison</title>
<style>body{{font-family:sans-serif}} table{{border-collapse:collapse}}
td,th{{border:1px solid #999;padding:2px 6px;text-align:right;white-space:nowrap;font-size:13px}} img{{max-width:48%;margin:4px}}</style>
</head><body><h1>Comparison against {html.escape(reference)}</h1>
<p>MAE, MSE, RMSE, PSNR, relMSE and SSIM computed on {html.escape(metrics_space)} values
(--metrics-space); FLIP on linear values.</p>
<table><tr>{head}</tr>
{body}</table>
{notes}<h2>Columns</h2>
{_legend(cols)}
<p>Full definitions: refrender's scripts/README.md (Comparing images).</p>
{figures}</body></html>
"""
    safefiles.write_text(os.path.join(out_dir, "index.html"), page, inputs)


def _fmt(v):
    if v is None:
        return "n/a"
    return f"{v:.6g}" if isinstance(v, float) else str(v)
