"""Image loading and error metrics for compare.py (and its tests).

Images are read with OpenImageIO and converted to linear float RGB. Metrics
(x = test, y = reference, means over the valid pixels and the 3 channels):
  MAE    = mean |x - y|
  MSE    = mean (x - y)^2,  RMSE = sqrt(MSE)
  PSNR   = 10 log10(peak^2 / MSE)  (peak = 1 unless --psnr-peak)
  relMSE = mean (x - y)^2 / (y^2 + 0.01)   (epsilon 0.01 stated here)
  SSIM   = scikit-image structural_similarity (Wang et al. 2004), Gaussian
           weights sigma 1.5, on linear RGB clamped to [0, peak], mean of the
           per-pixel map over valid pixels
  FLIP   = mean of the per-pixel LDR-FLIP map (flip.py)
  HDR-FLIP = mean of the per-pixel HDR-FLIP map (flip.py)
"""
import math

import numpy as np
import OpenImageIO as oiio

import flip
import safefiles

REL_EPS = 0.01


class CompareError(Exception):
    """A user-facing error: bad file, size mismatch, bad option."""


class Image:
    def __init__(self, path, rgb, alpha, stderr, colorspace, header):
        self.path, self.rgb, self.alpha, self.stderr = path, rgb, alpha, stderr
        self.colorspace, self.header = colorspace, header


def _detect_colorspace(spec):
    cs = spec.get_string_attribute("oiio:ColorSpace", "").lower()
    if "srgb" in cs:
        return "srgb"
    if "linear" in cs or "lin_" in cs or "acescg" in cs:
        return "linear"
    return "linear" if spec.format.basetype in (oiio.FLOAT, oiio.HALF, oiio.DOUBLE) else "srgb"


def _channel(pixels, names, wanted):
    for w in wanted:
        if w in names:
            return pixels[:, :, names.index(w)].astype(np.float64)
    return None


def read_channels(path, unassociated_alpha=True):
    """Every channel of an image by name (float32 planes), its spec and its
    header attributes: the one image reader of the scripts and tests. A path
    that is not a regular file (a FIFO would block the read) is refused
    before it is opened."""
    try:
        safefiles.require_regular(path)
    except safefiles.FileRefused as e:
        raise CompareError(str(e)) from None
    config = oiio.ImageSpec()
    if unassociated_alpha:
        config.attribute("oiio:UnassociatedAlpha", 1)  # PNG alpha as stored, not premultiplied
    inp = oiio.ImageInput.open(str(path), config)
    if not inp:
        raise CompareError(f"{path}: cannot read image: {oiio.geterror()}")
    spec = inp.spec()
    pixels = inp.read_image(oiio.FLOAT)
    inp.close()
    if pixels is None:
        raise CompareError(f"{path}: cannot decode pixels")
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    channels = {name: pixels[:, :, i] for i, name in enumerate(spec.channelnames)}
    return channels, spec, {a.name: a.value for a in spec.extra_attribs}


def check_written(path):
    """Raises OSError unless the image file at path decodes in full: the
    check safefiles.write_file makes before a picture is put in place
    (OpenImageIO's PNG writer does not report a full disk)."""
    inp = oiio.ImageInput.open(str(path))
    pixels = inp.read_image(oiio.FLOAT) if inp else None
    if inp:
        inp.close()
    if pixels is None:
        raise OSError(f"the written image does not read back ({oiio.geterror() or 'truncated'}; disk full?)")


def read_image(path, colorspace="auto"):
    """Reads any OpenImageIO format as linear RGB (+ alpha, + refrender's
    standard-error channels stderr.R/G/B when present)."""
    channels, spec, header = read_channels(path)
    pixels = np.stack(list(channels.values()), axis=-1)
    names = list(spec.channelnames)
    if spec.nchannels < 3 and names[0] not in ("R", "Y"):
        names = ["Y"] + names[1:]
    planes = []
    for c in "RGB":  # grey images repeat their single channel
        plane = _channel(pixels, names, [c, "Y"])
        planes.append(plane if plane is not None else pixels[:, :, 0].astype(np.float64))
    rgb = np.stack(planes, axis=-1)
    space = _detect_colorspace(spec) if colorspace == "auto" else colorspace
    if space == "srgb":
        rgb = flip.srgb_to_linear(rgb)
    alpha = _channel(pixels, names, ["A"])
    se = [_channel(pixels, names, [f"stderr.{c}"]) for c in "RGB"]
    stderr = np.stack(se, axis=-1) if all(s is not None for s in se) else None
    header["_unassociated"] = spec.get_int_attribute("oiio:UnassociatedAlpha", 0)
    return Image(str(path), rgb, alpha, stderr, space, header)


def scene_background(img):
    """The background a refrender image's RGB already holds where its
    coverage (alpha) is below 1 (header refrender:background), or None."""
    text = img.header.get("refrender:background")
    if text is None:
        return None
    try:
        vals = [float(v) for v in str(text).split()]
    except ValueError:
        vals = []
    if len(vals) != 3:
        raise CompareError(f"{img.path}: refrender:background is not three numbers: '{text}'")
    return np.asarray(vals)


def composite(img, background):
    """Alpha over a background color. refrender's RGB is the covered
    surfaces plus its own background times (1 - coverage): that background
    is swapped for the new one. Other files: straight alpha when stored
    unassociated (PNG), premultiplied otherwise (EXR)."""
    if img.alpha is None:
        return img.rgb
    a = img.alpha[..., None]
    bg = np.asarray(background, dtype=np.float64)
    own = scene_background(img)
    if own is not None:
        return img.rgb + (bg - own) * (1 - a)
    return img.rgb * a + bg * (1 - a) if img.header.get("_unassociated") else img.rgb + bg * (1 - a)


def basic_metrics(ref, test, valid, peak=1.0):
    d = (test - ref)[valid]
    y = ref[valid]
    mse = float(np.mean(d ** 2))
    return {
        "MAE": float(np.mean(np.abs(d))),
        "MSE": mse,
        "RMSE": float(np.sqrt(mse)),
        "PSNR": float("inf") if mse == 0 else float(10 * np.log10(peak ** 2 / mse)),
        "relMSE": float(np.mean(d ** 2 / (y ** 2 + REL_EPS))),
    }


def ssim_map(ref, test, peak=1.0):
    r, t = np.clip(ref, 0, peak), np.clip(test, 0, peak)
    # scikit-image's Gaussian window (sigma 1.5, truncated at 3.5 sigma) is 11 pixels wide
    if min(r.shape[:2]) < 11:
        raise CompareError("SSIM needs images (or crops) of at least 11x11 pixels")
    # imported here, not at the top: skimage.metrics pulls in scipy.stats, a third of a second of
    # start-up that every script reading an image paid, though only SSIM uses it
    from skimage.metrics import structural_similarity
    _, full = structural_similarity(r, t, channel_axis=-1, data_range=peak, gaussian_weights=True,
                                    sigma=1.5, use_sample_covariance=False, full=True)
    return full.mean(axis=-1)


def loglog_fit(counts, errors):
    """(slope, intercept) of the least-squares line of log error against
    log count, over the errors above 0 (an exact 0 has no logarithm); NaNs
    without two of them."""
    pts = [(math.log(c), math.log(e)) for c, e in zip(counts, errors) if e > 0]
    if len(pts) < 2:
        return float("nan"), float("nan")
    slope, intercept = np.polyfit([p[0] for p in pts], [p[1] for p in pts], 1)
    return float(slope), float(intercept)


def stderr_fraction(se, ref, test, valid, k):
    """Fraction of valid pixels (2-D mask) where some channel differs from
    the reference by more than k standard errors se of the reference."""
    beyond = np.any(np.abs(test - ref) > k * se, axis=-1)
    return float(np.mean(beyond[valid]))
