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

from . import flip, safefiles


class _LazyOIIO:
    """OpenImageIO's module, imported on first use: reading and writing files needs it (Debian's
    python3-openimageio), the metrics on arrays do not, so `import refrender` works where only numpy is."""

    def __getattr__(self, name):
        import OpenImageIO
        return getattr(OpenImageIO, name)


oiio = _LazyOIIO()

REL_EPS = 0.01


class CompareError(Exception):
    """A user-facing error: bad file, size mismatch, bad option."""


class Image:
    def __init__(self, path, rgb, alpha, stderr, encoding, header):
        self.path, self.rgb, self.alpha, self.stderr = path, rgb, alpha, stderr
        self.encoding, self.header = encoding, header
        self.colorspace = encoding.space
        self.blur_space = header.get("refrender:blurSpace")


class Encoding:
    """What a file's RGB holds: space "srgb" (display-encoded values) or
    "linear" (linear light), where that was read (source), and whether the
    file said it (known False: assumed, and said so by every script)."""

    def __init__(self, space, source, known=True):
        self.space, self.source, self.known = space, source, known

    def __str__(self):
        return f"{self.space} ({self.source})"


def exr_header_names(path):
    """The attribute names an OpenEXR file's (first) header holds, read
    from the file itself: OpenImageIO reports oiio:ColorSpace "Linear" for
    every EXR that does not state one, so its spec cannot tell a stated
    colour space from none. Layout: OpenEXR's file layout document (magic,
    version, then name NUL type NUL int32 size, value, up to an empty name);
    None for a file that is not OpenEXR."""
    names = set()
    with open(path, "rb") as f:
        data = f.read(1 << 20)
    if data[:4] != b"\x76\x2f\x31\x01":
        return None
    pos = 8
    while pos < len(data) and data[pos] != 0:
        name_end = data.find(b"\0", pos)
        type_end = data.find(b"\0", name_end + 1)
        if name_end < 0 or type_end < 0 or type_end + 5 > len(data):
            break
        names.add(data[pos:name_end].decode("latin-1"))
        pos = type_end + 5 + int.from_bytes(data[type_end + 1:type_end + 5], "little")
    return names


def _exr_header_end(data):
    """The offset of the NUL that ends an OpenEXR file's (single) header."""
    pos = 8
    while data[pos] != 0:
        type_end = data.index(b"\0", data.index(b"\0", pos) + 1)
        pos = type_end + 5 + int.from_bytes(data[type_end + 1:type_end + 5], "little")
    return pos


def tag_exr(path, attributes):
    """Adds string attributes to a single-part OpenEXR file in place: how a
    script states oiio:ColorSpace, which OpenImageIO's EXR writer leaves out
    (it writes no "oiio:" attribute) while its reader honours it. The
    attributes go at the end of the header and every offset in the chunk
    table after it moves by their size (OpenEXR file layout: the table's
    offsets count from the file's start)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"\x76\x2f\x31\x01" or int.from_bytes(data[4:8], "little") & 0x1800:
        raise CompareError(f"{path}: not a single-part OpenEXR file: cannot add {', '.join(attributes)}")
    end = _exr_header_end(data)
    extra = b"".join(name.encode() + b"\0string\0" + len(value.encode()).to_bytes(4, "little") + value.encode()
                     for name, value in attributes.items())
    first = int.from_bytes(data[end + 1:end + 9], "little")
    chunks = (first - end - 1) // 8
    table = b"".join((int.from_bytes(data[end + 1 + 8 * i:end + 9 + 8 * i], "little") + len(extra)).to_bytes(8, "little")
                     for i in range(chunks))
    with open(path, "wb") as f:
        f.write(data[:end] + extra + data[end:end + 1] + table + data[end + 1 + 8 * chunks:])


def _named_space(name):
    n = name.lower()
    if "srgb" in n and not n.startswith("lin"):
        return "srgb"
    if "linear" in n or n.startswith("lin_") or "acescg" in n:
        return "linear"
    return None


def _detect_encoding(path, spec, header):
    """The encoding a file states (oiio:ColorSpace), else what an older
    refrender EXR's refrender:blurSpace implies, else the conventions: 8-
    and 16-bit integer images are sRGB (as PNG and JPEG are written), float
    ones linear light, assumed (known False)."""
    is_float = spec.format.basetype in (oiio.FLOAT, oiio.HALF, oiio.DOUBLE)
    stated = spec.get_string_attribute("oiio:ColorSpace", "")
    exr_names = exr_header_names(path)
    if exr_names is not None and "oiio:ColorSpace" not in exr_names:
        stated = ""
    if stated:
        space = _named_space(stated)
        if space:
            return Encoding(space, f'oiio:ColorSpace "{stated}"')
        return Encoding("srgb" if not is_float else "linear",
                        f'oiio:ColorSpace "{stated}" not understood: assumed', False)
    blur = header.get("refrender:blurSpace")
    if blur is not None or any(k.startswith("refrender:") for k in header):
        # refrender before oiio:ColorSpace (before refrender:blurSpace every render averaged as model):
        # a Gaussian model's colours unless decoded, else linear light
        gaussians = header.get("refrender:gaussians", "none") != "none"
        space = "srgb" if gaussians and blur != "linear" else "linear"
        return Encoding(space, f"refrender:blurSpace {blur or 'absent: model'}" +
                        (" of a Gaussian model" if gaussians else ""))
    if is_float:
        return Encoding("linear", "float data with no oiio:ColorSpace: assumed linear", False)
    return Encoding("srgb", f"{spec.format} data: sRGB by default")


# refrender's own per-pixel statistics, never a colour layer
OWN_LAYERS = ("stderr.", "variance.")


def rgb_prefix(path, names):
    """The prefix of the R, G and B channels: "" for plain names, else one
    layer's (Blender writes Combined.R or ViewLayer.Combined.R). A missing
    colour channel is refused, naming the channels found: no other channel
    stands in for it."""
    if all(c in names for c in "RGB"):
        return ""
    layers = sorted({n[:-1] for n in names if n.endswith(("R", "G", "B")) and n[:-1].endswith(".")
                     and all(n[:-1] + c in names for c in "RGB") and n[:-1] not in OWN_LAYERS})
    combined = [p for p in layers if p.rstrip(".").split(".")[-1] == "Combined"]
    if len(layers) == 1 or len(combined) == 1:
        return layers[0] if len(layers) == 1 else combined[0]
    found = ", ".join(names)
    if layers:
        raise CompareError(f"{path}: several colour layers ({', '.join(p[:-1] for p in layers)}): none is "
                           f"'Combined', so which one is the image is not known (channels: {found})")
    plain = [c for c in "RGB" if c in names]
    if plain:
        raise CompareError(f"{path}: no channel {', '.join(c for c in 'RGB' if c not in plain)} beside "
                           f"{', '.join(plain)}; channels found: {found}")
    if "Y" in names:
        return None  # a grey image: its one channel is each of R, G and B
    raise CompareError(f"{path}: no R, G and B channels (plain or under one layer such as Combined.R); "
                       f"channels found: {found}")


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
    standard-error channels stderr.R/G/B when present), the channels found
    by name (rgb_prefix) and decoded as the file's encoding says
    (_detect_encoding; colorspace "srgb" or "linear" overrides it)."""
    channels, spec, header = read_channels(path)
    names = list(spec.channelnames)
    prefix = rgb_prefix(path, names)
    plane = (lambda c: channels["Y"]) if prefix is None else (lambda c: channels[prefix + c])
    rgb = np.stack([plane(c).astype(np.float64) for c in "RGB"], axis=-1)
    encoding = (_detect_encoding(path, spec, header) if colorspace == "auto"
                else Encoding(colorspace, "given on the command line"))
    if encoding.space == "srgb":
        rgb = flip.srgb_to_linear(rgb)
    alpha = channels.get((prefix or "") + "A")
    alpha = alpha.astype(np.float64) if alpha is not None else None
    se = [channels.get(f"stderr.{c}") for c in "RGB"]
    stderr = np.stack(se, axis=-1).astype(np.float64) if all(s is not None for s in se) else None
    header["_unassociated"] = spec.get_int_attribute("oiio:UnassociatedAlpha", 0)
    return Image(str(path), rgb, alpha, stderr, encoding, header)


def encoding_warnings(ref, test):
    """What a score of test against ref cannot vouch for: an encoding
    assumed rather than stated, or the two made in different blur spaces
    (refrender:blurSpace: the time average taken over other values)."""
    out = [f"{img.path}: colour encoding not stated, {img.encoding}" for img in (ref, test) if not img.encoding.known]
    if ref.blur_space and test.blur_space and ref.blur_space != test.blur_space:
        out.append(f"{test.path} was averaged in blur space {test.blur_space}, the reference {ref.path} in "
                   f"{ref.blur_space}: their difference includes the difference of the two averages")
    return out


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
