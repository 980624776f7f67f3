"""FLIP and HDR-FLIP image difference, implemented from the papers.

LDR-FLIP: P. Andersson, J. Nilsson, T. Akenine-Moller, M. Oskarsson, K. Astrom,
M. D. Fairchild, "FLIP: A Difference Evaluator for Alternating Images", Proc. ACM
Comput. Graph. Interact. Tech. 3(2), 2020 (HPG 2020).
HDR-FLIP: P. Andersson, J. Nilsson, P. Shirley, T. Akenine-Moller, "Visualizing Errors
in Rendered High Dynamic Range Images", Eurographics 2021 short papers.

All functions take *linear* RGB float arrays of shape (H, W, 3). LDR-FLIP clamps its
inputs to [0, 1] (the paper's sRGB input decoded to linear); HDR-FLIP tone maps first.
"""
import numpy as np


def convolve(*args, **kwargs):
    """scipy.ndimage.convolve, imported on first use (FLIP needs scipy; importing the package does not)."""
    from scipy.ndimage import convolve as scipy_convolve
    return scipy_convolve(*args, **kwargs)


DEFAULT_PPD = 67.02  # 0.7 m viewing distance, 0.7 m wide 3840-pixel monitor (paper)

# linear sRGB (D65) to CIE XYZ
RGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                       [0.2126729, 0.7151522, 0.0721750],
                       [0.0193339, 0.1191920, 0.9503041]])
XYZ_TO_RGB = np.linalg.inv(RGB_TO_XYZ)
WHITE = RGB_TO_XYZ @ np.ones(3)  # reference white of YCxCz and L*a*b*

# Spatial contrast sensitivity as sums of Gaussians (paper, sec. 4.1):
# (a1, b1, a2, b2) for the achromatic, red-green and blue-yellow channels.
CSF = {"A": (1.0, 0.0047, 0.0, 1e-5), "RG": (1.0, 0.0053, 0.0, 1e-5),
       "BY": (34.1, 0.04, 13.5, 0.025)}
QC, PC, PT = 0.7, 0.4, 0.95  # color difference exponent and remapping knee
QF, GW = 0.5, 0.082          # feature exponent; feature filter width in degrees


def srgb_to_linear(c):
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c):
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def luminance(rgb):
    return rgb @ RGB_TO_XYZ[1]


def linear_to_ycxcz(rgb):
    xyz = (rgb @ RGB_TO_XYZ.T) / WHITE
    y = 116.0 * xyz[..., 1] - 16.0
    cx = 500.0 * (xyz[..., 0] - xyz[..., 1])
    cz = 200.0 * (xyz[..., 1] - xyz[..., 2])
    return np.stack([y, cx, cz], axis=-1)


def ycxcz_to_linear(ycc):
    yn = (ycc[..., 0] + 16.0) / 116.0
    xyz = np.stack([ycc[..., 1] / 500.0 + yn, yn, yn - ycc[..., 2] / 200.0], axis=-1) * WHITE
    return xyz @ XYZ_TO_RGB.T


def linear_to_lab(rgb):
    t = (rgb @ RGB_TO_XYZ.T) / WHITE
    d = 6.0 / 29.0
    f = np.where(t > d ** 3, np.cbrt(t), t / (3 * d * d) + 4.0 / 29.0)
    return np.stack([116.0 * f[..., 1] - 16.0, 500.0 * (f[..., 0] - f[..., 1]),
                     200.0 * (f[..., 1] - f[..., 2])], axis=-1)


def hunt(lab):
    """Hunt effect: chroma scaled by lightness, a* and b* times 0.01 L*."""
    return np.stack([lab[..., 0], 0.01 * lab[..., 0] * lab[..., 1],
                     0.01 * lab[..., 0] * lab[..., 2]], axis=-1)


def hyab(p, q):
    """HyAB distance: |dL| + Euclidean distance in (a, b)."""
    d = p - q
    return np.abs(d[..., 0]) + np.hypot(d[..., 1], d[..., 2])


def _csf_kernel(ppd, a1, b1, a2, b2, radius):
    x = np.arange(-radius, radius + 1) / ppd  # degrees
    d2 = x[None, :] ** 2 + x[:, None] ** 2
    g = a1 * np.sqrt(np.pi / b1) * np.exp(-np.pi ** 2 * d2 / b1)
    g = g + a2 * np.sqrt(np.pi / b2) * np.exp(-np.pi ** 2 * d2 / b2)
    return g / g.sum()


def _csf_filter(ycc, ppd):
    b_max = max(max(p[1], p[3]) for p in CSF.values())
    radius = int(np.ceil(3.0 * np.sqrt(b_max / (2.0 * np.pi ** 2)) * ppd))
    out = np.empty_like(ycc)
    for i, name in enumerate(("A", "RG", "BY")):
        out[..., i] = convolve(ycc[..., i], _csf_kernel(ppd, *CSF[name], radius), mode="nearest")
    return out


def _feature_kernels(ppd):
    """First (edge) and second (point) derivative of a Gaussian of std
    0.5 * GW * ppd pixels; each sign's weights normalised to sum to +-1."""
    sigma = 0.5 * GW * ppd
    r = int(np.ceil(3.0 * sigma))
    x = np.arange(-r, r + 1, dtype=np.float64)
    X, Y = np.meshgrid(x, x)
    g = np.exp(-(X ** 2 + Y ** 2) / (2 * sigma ** 2))
    edge = -X * g
    edge /= edge[edge > 0].sum()
    point = (X ** 2 / sigma ** 2 - 1.0) * g
    pos, neg = point > 0, point < 0
    point[pos] /= point[pos].sum()
    point[neg] /= -point[neg].sum()
    return edge, point


def _features(achromatic, ppd):
    edge, point = _feature_kernels(ppd)
    ex = convolve(achromatic, edge, mode="nearest")
    ey = convolve(achromatic, edge.T, mode="nearest")
    px = convolve(achromatic, point, mode="nearest")
    py = convolve(achromatic, point.T, mode="nearest")
    return np.hypot(ex, ey), np.hypot(px, py)


def _max_color_error():
    green, blue = hunt(linear_to_lab(np.array([0.0, 1.0, 0.0]))), hunt(linear_to_lab(np.array([0.0, 0.0, 1.0])))
    return hyab(green, blue) ** QC


def _remap_color(delta):
    cmax = _max_color_error()
    knee = PC * cmax
    return np.where(delta < knee, PT / knee * delta, PT + (delta - knee) / (cmax - knee) * (1.0 - PT))


def ldr_flip(reference, test, ppd=DEFAULT_PPD):
    """Per-pixel LDR-FLIP in [0, 1] of two linear RGB images (clamped to [0, 1])."""
    ref = np.clip(np.asarray(reference, dtype=np.float64), 0.0, 1.0)
    tst = np.clip(np.asarray(test, dtype=np.float64), 0.0, 1.0)
    ref_ycc, tst_ycc = linear_to_ycxcz(ref), linear_to_ycxcz(tst)
    # color: CSF-filter in YCxCz, back to linear RGB clamped, Hunt-adjusted Lab, HyAB
    ref_f = np.clip(ycxcz_to_linear(_csf_filter(ref_ycc, ppd)), 0.0, 1.0)
    tst_f = np.clip(ycxcz_to_linear(_csf_filter(tst_ycc, ppd)), 0.0, 1.0)
    color = _remap_color(hyab(hunt(linear_to_lab(ref_f)), hunt(linear_to_lab(tst_f))) ** QC)
    # features: edges and points of the normalised achromatic channel Y/Yn
    ref_e, ref_p = _features((ref_ycc[..., 0] + 16.0) / 116.0, ppd)
    tst_e, tst_p = _features((tst_ycc[..., 0] + 16.0) / 116.0, ppd)
    feature = (np.maximum(np.abs(ref_e - tst_e), np.abs(ref_p - tst_p)) / np.sqrt(2.0)) ** QF
    return np.clip(color, 0.0, 1.0) ** (1.0 - feature)


def aces(x):
    """ACES filmic tone curve (Narkowicz 2015 fit) with HDR-FLIP's 0.6 input scale."""
    x = 0.6 * np.asarray(x, dtype=np.float64)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def _tone_input_for(output, lo=0.0, hi=1e4):
    for _ in range(200):  # bisection: aces is increasing
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if aces(mid) < output else (lo, mid)
    return 0.5 * (lo + hi)


def hdr_exposures(reference):
    """HDR-FLIP's automatic exposure range: the start exposure maps the
    reference's largest luminance, the stop exposure its median luminance, to
    tone-mapped 0.85. Raises ValueError when the median luminance is not
    positive (e.g. splats on a black background): pass exposures explicitly."""
    y = luminance(np.asarray(reference, dtype=np.float64)).ravel()
    y_max, y_med = np.max(y), np.median(y)
    if not (y_med > 0 and y_max > 0):
        raise ValueError("HDR-FLIP needs a positive median luminance for automatic exposures; "
                         "give --hdr-exposures START,STOP")
    x85 = _tone_input_for(0.85)
    return float(np.log2(x85 / y_max)), float(np.log2(x85 / y_med))


def hdr_flip(reference, test, ppd=DEFAULT_PPD, exposures=None):
    """Per-pixel HDR-FLIP: the maximum over exposures c in [start, stop]
    (N = max(2, ceil(stop - start)) evenly spaced) of LDR-FLIP of the images
    scaled by 2^c and tone mapped."""
    ref = np.asarray(reference, dtype=np.float64)
    tst = np.asarray(test, dtype=np.float64)
    start, stop = exposures if exposures is not None else hdr_exposures(ref)
    n = max(2, int(np.ceil(stop - start)))
    result = np.zeros(ref.shape[:2])
    for c in np.linspace(start, stop, n):
        scale = 2.0 ** c
        result = np.maximum(result, ldr_flip(aces(ref * scale), aces(tst * scale), ppd))
    return result


def weighted_percentile(values, q):
    """Percentile q (0-100) of the FLIP values weighted by the values
    themselves, as in the paper's weighted histogram (larger errors count
    more). Returns 0 when every value is 0."""
    v = np.sort(np.asarray(values, dtype=np.float64).ravel())
    cum = np.cumsum(v)
    if cum[-1] <= 0:
        return 0.0
    return float(v[np.searchsorted(cum, q / 100.0 * cum[-1])]) if q < 100 else float(v[-1])
