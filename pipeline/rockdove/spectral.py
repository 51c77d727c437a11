"""Spectral colour: reflectance spectrum -> CIE XYZ (D65, CIE 1931 2 deg) -> working RGB; CIELAB and dE2000.

Data: the CIE 1931 2 degree colour-matching functions (1 nm, 360-830 nm) and the CIE D65 spectral power
distribution (5 nm, 300-780 nm) are colour-science's tables (``colour.MSDS_CMFS``,
``colour.SDS_ILLUMINANTS``), linearly interpolated onto the requested wavelengths. The usable domain is
:data:`WAVELENGTH_RANGE_NM` = 360-780 nm, where both tables are defined (D65 ends at 780 nm).

Normalisation (CIE 15:2004, sec. 7.1, with k chosen so that a perfect reflector has Y = 1):

    X = sum_i w_i R_i S_i xbar_i / sum_i w_i S_i ybar_i     (likewise Y, Z)

where w_i are trapezoid-rule weights on the given, possibly non-uniform, strictly increasing grid
(w_0 = (l_1 - l_0) / 2, w_i = (l_{i+1} - l_{i-1}) / 2, w_{N-1} = (l_{N-1} - l_{N-2}) / 2). On a uniform grid
this equals colour-science's ASTM E308 / integration results up to their own method differences.

Working colour spaces (MaterialX names): ``lin_rec709`` (ITU-R BT.709 primaries, D65 white) and ``acescg``
(ACES AP1 primaries, ACES white, ~D60). XYZ is converted with colour-science's RGB colourspace matrices and a
Bradford chromatic adaptation from the reference white (below) to the colourspace's white point: Bradford is
what MaterialX's ``lin_rec709_to_acescg`` matrix uses (its first column 0.6131, 0.3395, 0.0474). The
reference white is the XYZ of the D65 table itself integrated with the CIE 1931 2 deg observer on the 1 nm
grid over 360-780 nm (x, y = 0.31272, 0.32903); adapting from it rather than from the rounded
(0.3127, 0.3290) makes a perfect reflector exactly (1, 1, 1) in ``lin_rec709`` (the difference is ~1e-4).
Results are not clipped: thin-film colours are often out of gamut (negative components).

CIELAB (CIE 15:2004, eq. 8.1-8.3, with the exact constants 216/24389 and 24389/27) uses the same reference
white at Y = 1; CIEDE2000 follows Sharma, Wu and Dalal (2005), eq. 1-24; the sRGB transfer functions are
IEC 61966-2-1. These three formulas are written here in numpy and tested against colour-science's
``XYZ_to_Lab``, ``delta_E(..., "CIE 2000")`` and ``cctf_encoding/decoding(..., "sRGB")`` (tests/test_spectral.py).

Keeping colour-science off the hot path: importing colour-science takes ~1 s (scipy.interpolate, its
colour models), far more than a LUT bake. The only things taken from it are data (the CMF and illuminant
tables, the RGB colourspace matrices), so they are read from colour-science once and kept as ``.npz`` files in
``$XDG_CACHE_HOME/rockdove/colour-science-<key>/`` (``~/.cache`` by default; :func:`colour_data`), keyed by the
code that computes them, the installed distributions and Python (:func:`rockdove.sources.cache_dir`). A
film-only rebuild then bakes, measures and encodes its LUT without importing colour-science. If the folder
cannot be written, the values are simply recomputed in each process.
"""

from __future__ import annotations

import zipfile
from functools import lru_cache

import numpy as np

WAVELENGTH_RANGE_NM = (360.0, 780.0)
DEFAULT_ILLUMINANT = "D65"
DEFAULT_OBSERVER = "CIE 1931 2 Degree Standard Observer"
COLOUR_SPACES = ("lin_rec709", "acescg")
# MaterialX colour space name -> colour-science RGB colourspace name.
_COLOURSPACE_NAMES = {"lin_rec709": "ITU-R BT.709", "acescg": "ACEScg"}
CHROMATIC_ADAPTATION = "Bradford"  # as MaterialX's lin_rec709 <-> acescg matrices
_REFERENCE_STEP_NM = 1.0  # grid of the reference white (the CMFS table's own step)


def _colour():
    from ._compat import import_colour  # imported lazily: colour-science takes ~1 s to import

    return import_colour()


def _check_wavelengths(wavelength_nm) -> np.ndarray:
    try:
        lam = np.asarray(wavelength_nm, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"wavelength_nm must be real numbers, got {wavelength_nm!r}") from None
    lo, hi = WAVELENGTH_RANGE_NM
    if lam.size and not (lam.min() >= lo and lam.max() <= hi):
        bad = lam[~((lam >= lo) & (lam <= hi))].flat[0].item()
        raise ValueError(f"wavelength_nm must be within [{lo:g}, {hi:g}] nm (colour's D65 table ends at 780), got {bad!r}")
    return lam


def colour_data(name: str, compute, keys: tuple[str, ...]) -> dict:
    """Arrays derived from colour-science's data, cached on disk by what computes them (module docstring).

    Parameters
    ----------
    name : str
        File stem, unique per content (e.g. ``"tables-D65-CIE_1931_2_Degree_Standard_Observer"``).
    compute : callable () -> dict of str -> ndarray
        Builds the arrays (imports colour-science); called when the file is missing, unreadable or lacks one of
        ``keys``.
    keys : tuple of str
        The arrays the caller reads.

    Returns
    -------
    dict of str -> ndarray (read-only)
    """
    from .sources import cache_dir

    path = cache_dir("colour-science", compute) / f"{name}.npz"
    arrays = None
    try:
        with np.load(path, allow_pickle=False) as f:
            arrays = {k: f[k] for k in f.files}
        if not set(keys) <= set(arrays):
            arrays = None  # written by another layout of the same name: rebuild it
    except (OSError, ValueError, EOFError, zipfile.BadZipFile):  # missing, or torn by a crash: recompute below
        pass
    if arrays is None:
        import io

        from .resources import write_cached

        arrays = {k: np.ascontiguousarray(v, dtype=np.float64) for k, v in compute().items()}
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        write_cached(path, buf.getvalue())
    for a in arrays.values():
        a.setflags(write=False)
    return arrays


@lru_cache(maxsize=8)
def _tables(illuminant: str, observer: str):
    def compute() -> dict:
        colour = _colour()
        if observer not in colour.MSDS_CMFS:
            raise ValueError(f"observer must be one of colour.MSDS_CMFS (e.g. {DEFAULT_OBSERVER!r}), got {observer!r}")
        if illuminant not in colour.SDS_ILLUMINANTS:
            raise ValueError(f"illuminant must be one of colour.SDS_ILLUMINANTS (e.g. 'D65'), got {illuminant!r}")
        cmfs = colour.MSDS_CMFS[observer]
        sd = colour.SDS_ILLUMINANTS[illuminant]
        lo, hi = WAVELENGTH_RANGE_NM
        for what, table in (("observer", cmfs), ("illuminant", sd)):
            if table.wavelengths[0] > lo or table.wavelengths[-1] < hi:
                raise ValueError(f"{what} {table.name!r} does not cover {lo:g}-{hi:g} nm")
        return {"cmfs_wavelength_nm": cmfs.wavelengths, "cmfs": cmfs.values,
                "illuminant_wavelength_nm": sd.wavelengths, "illuminant": sd.values}

    slug = "".join(c if c.isalnum() or c in "-." else "_" for c in f"{illuminant}-{observer}")
    t = colour_data(f"tables-{slug}", compute,
                    ("cmfs_wavelength_nm", "cmfs", "illuminant_wavelength_nm", "illuminant"))
    return t["cmfs_wavelength_nm"], t["cmfs"], t["illuminant_wavelength_nm"], t["illuminant"]


def cmfs_illuminant(wavelength_nm, illuminant=DEFAULT_ILLUMINANT, observer=DEFAULT_OBSERVER):
    """Colour-matching functions and illuminant, linearly interpolated onto the given wavelengths.

    Parameters
    ----------
    wavelength_nm : array_like, (N,), nm, within :data:`WAVELENGTH_RANGE_NM`
    illuminant : str
        Key of ``colour.SDS_ILLUMINANTS``; default "D65".
    observer : str
        Key of ``colour.MSDS_CMFS``; default the CIE 1931 2 degree observer.

    Returns
    -------
    cmfs : ndarray, (N, 3), float64
        xbar, ybar, zbar.
    S : ndarray, (N,), float64
        Relative spectral power of the illuminant (colour's scale, S(560) = 100 for D65).
    """
    lam = _check_wavelengths(wavelength_nm)
    cw, cv, sw, sv = _tables(illuminant, observer)
    cmfs = np.stack([np.interp(lam, cw, cv[:, k]) for k in range(3)], axis=-1)
    return cmfs, np.interp(lam, sw, sv)


def _trapezoid_weights(lam: np.ndarray) -> np.ndarray:
    w = np.empty_like(lam)
    dl = np.diff(lam)
    w[0], w[-1] = dl[0] / 2, dl[-1] / 2
    w[1:-1] = (dl[:-1] + dl[1:]) / 2
    return w


def spectral_weights(wavelength_nm, illuminant=DEFAULT_ILLUMINANT, colour_space=None) -> np.ndarray:
    """Quadrature weights W with ``XYZ = R @ W`` for a reflectance R sampled on ``wavelength_nm``.

    ``W[i] = w_i S_i cmf_i / sum_j w_j S_j ybar_j`` with trapezoid weights w on the given grid (module
    docstring), so a perfect reflector (R = 1) gives Y = 1 exactly on any grid. With ``colour_space``
    the weights give working RGB instead: ``RGB = R @ W``.

    Parameters
    ----------
    wavelength_nm : array_like, (N,), nm, N >= 2, strictly increasing, within :data:`WAVELENGTH_RANGE_NM`
    illuminant : str, default "D65"
    colour_space : None or one of :data:`COLOUR_SPACES`

    Returns
    -------
    ndarray, (N, 3), float64
    """
    lam = _check_wavelengths(wavelength_nm)
    if lam.ndim != 1 or lam.size < 2:
        raise ValueError(f"wavelength_nm must be a 1-D grid of at least 2 wavelengths, got shape {lam.shape}")
    if not np.all(np.diff(lam) > 0):
        raise ValueError("wavelength_nm must be strictly increasing")
    cmfs, s = cmfs_illuminant(lam, illuminant)
    ws = _trapezoid_weights(lam) * s
    weights = cmfs * ws[:, None] / np.dot(ws, cmfs[:, 1])
    if colour_space is not None:
        weights = weights @ _xyz_to_rgb_matrix_t(colour_space)
    return weights


def reflectance_to_XYZ(R, wavelength_nm, illuminant=DEFAULT_ILLUMINANT, axis=-1) -> np.ndarray:
    """CIE XYZ (perfect reflector Y = 1) of reflectance spectra.

    Parameters
    ----------
    R : array_like, (..., N, ...), reflectance in [0, 1] (not checked: any real spectrum integrates)
    wavelength_nm : array_like, (N,), nm
    illuminant : str, default "D65"
    axis : int
        Axis of R along the wavelengths.

    Returns
    -------
    ndarray, R's shape with the wavelength axis removed and a trailing axis of 3 (X, Y, Z).
    """
    R = np.moveaxis(np.asarray(R, dtype=np.float64), axis, -1)
    lam = np.asarray(wavelength_nm, dtype=np.float64)
    if R.shape[-1] != lam.size:
        raise ValueError(f"R has {R.shape[-1]} samples along axis {axis} but wavelength_nm has {lam.size}")
    return R @ spectral_weights(lam, illuminant)


# --------------------------------------------------------------------------- colour spaces
@lru_cache(maxsize=4)
def _reference_white_XYZ(illuminant: str = DEFAULT_ILLUMINANT) -> tuple:
    """XYZ (Y = 1) of the illuminant integrated on the 1 nm grid over WAVELENGTH_RANGE_NM."""
    lo, hi = WAVELENGTH_RANGE_NM
    lam = np.arange(lo, hi + 0.5 * _REFERENCE_STEP_NM, _REFERENCE_STEP_NM)
    return tuple(float(v) for v in np.ones(lam.size) @ spectral_weights(lam, illuminant))


def reference_white_xy(illuminant: str = DEFAULT_ILLUMINANT) -> np.ndarray:
    """Chromaticity (x, y) of the reference white: the illuminant's own spectrum, CIE 1931 2 deg, 1 nm."""
    xyz = np.array(_reference_white_XYZ(illuminant))
    return xyz[:2] / xyz.sum()


def check_colour_space(colour_space) -> str:
    if colour_space not in COLOUR_SPACES:
        raise ValueError(f"colour_space must be one of {COLOUR_SPACES}, got {colour_space!r}")
    return colour_space


@lru_cache(maxsize=4)
def _xyz_to_rgb_matrix_t(colour_space: str) -> np.ndarray:
    """(3, 3) matrix M with ``rgb = XYZ @ M`` (row vectors), built with colour.XYZ_to_RGB (cached on disk)."""
    check_colour_space(colour_space)
    white = reference_white_xy()

    def compute() -> dict:
        colour = _colour()
        m = colour.XYZ_to_RGB(np.eye(3), colour.RGB_COLOURSPACES[_COLOURSPACE_NAMES[colour_space]],
                              illuminant=white, chromatic_adaptation_transform=CHROMATIC_ADAPTATION,
                              apply_cctf_encoding=False)
        return {"matrix": m}

    # the white is derived from the tables; naming the file by it keeps a matrix from outliving its white
    return colour_data(f"xyz-to-{colour_space}-{CHROMATIC_ADAPTATION}-{white[0]:.15f}-{white[1]:.15f}",
                       compute, ("matrix",))["matrix"]


@lru_cache(maxsize=1)
def _rec709_luminance() -> np.ndarray:
    """Y row of ITU-R BT.709's RGB -> XYZ matrix (colour-science's), (3,): Y = rgb @ weights."""
    def compute() -> dict:
        return {"weights": np.asarray(_colour().RGB_COLOURSPACES["ITU-R BT.709"].matrix_RGB_to_XYZ)[1]}

    return colour_data("rec709-luminance", compute, ("weights",))["weights"]


def XYZ_to_RGB(XYZ, colour_space="lin_rec709") -> np.ndarray:
    """Linear working RGB from CIE XYZ (reference D65 white at Y = 1 -> (1, 1, 1) in lin_rec709).

    Parameters
    ----------
    XYZ : array_like, (..., 3)
    colour_space : one of :data:`COLOUR_SPACES`

    Returns
    -------
    ndarray, (..., 3), float64, unclipped (out-of-gamut colours keep negative components).
    """
    return np.asarray(XYZ, dtype=np.float64) @ _xyz_to_rgb_matrix_t(check_colour_space(colour_space))


def RGB_to_XYZ(RGB, colour_space="lin_rec709") -> np.ndarray:
    """Inverse of :func:`XYZ_to_RGB`: (..., 3) linear RGB -> (..., 3) CIE XYZ."""
    m = _xyz_to_rgb_matrix_t(check_colour_space(colour_space))
    return np.asarray(RGB, dtype=np.float64) @ np.linalg.inv(m)


#: CIE 15:2004 CIELAB constants, exact rationals: epsilon = (6/29)^3, kappa = (29/3)^3.
_LAB_EPSILON = 216.0 / 24389.0
_LAB_KAPPA = 24389.0 / 27.0


def XYZ_to_Lab(XYZ) -> np.ndarray:
    """CIELAB (L in [0, 100]) of XYZ with the reference D65 white at Y = 1. (..., 3) -> (..., 3).

    CIE 15:2004 eq. 8.1-8.3: ``f(t) = t^(1/3)`` above epsilon, ``(kappa t + 16) / 116`` below;
    ``L = 116 f(Y/Yn) - 16``, ``a = 500 (f(X/Xn) - f(Y/Yn))``, ``b = 200 (f(Y/Yn) - f(Z/Zn))``.
    """
    xy = reference_white_xy()
    white = np.array([xy[0] / xy[1], 1.0, (1.0 - xy[0] - xy[1]) / xy[1]])
    t = np.asarray(XYZ, dtype=np.float64) / white
    f = np.where(t > _LAB_EPSILON, np.cbrt(t), (_LAB_KAPPA * t + 16.0) / 116.0)
    return np.stack([116.0 * f[..., 1] - 16.0, 500.0 * (f[..., 0] - f[..., 1]), 200.0 * (f[..., 1] - f[..., 2])],
                    axis=-1)


def Lab_to_XYZ(Lab) -> np.ndarray:
    """Inverse of :func:`XYZ_to_Lab` (CIE 15:2004 eq. 8.4-8.6, the same white). (..., 3) -> (..., 3)."""
    lab = np.asarray(Lab, dtype=np.float64)
    xy = reference_white_xy()
    white = np.array([xy[0] / xy[1], 1.0, (1.0 - xy[0] - xy[1]) / xy[1]])
    fy = (lab[..., 0] + 16.0) / 116.0
    f = np.stack([fy + lab[..., 1] / 500.0, fy, fy - lab[..., 2] / 200.0], axis=-1)
    t = np.where(f ** 3 > _LAB_EPSILON, f ** 3, (116.0 * f - 16.0) / _LAB_KAPPA)
    return t * white


def delta_E_2000(Lab_a, Lab_b) -> np.ndarray:
    """CIEDE2000 colour difference, k_L = k_C = k_H = 1; (..., 3), (..., 3) -> (...).

    Sharma, Wu and Dalal (2005), "The CIEDE2000 color-difference formula: implementation notes,
    supplementary test data, and mathematical observations", Color Res. Appl. 30(1), eq. 1-24 (hue angles
    in degrees; h' = 0 where a' = b' = 0; the mean hue and the hue difference follow their eq. 10 and 14).
    """
    L1, a1, b1 = np.moveaxis(np.asarray(Lab_a, dtype=np.float64), -1, 0)
    L2, a2, b2 = np.moveaxis(np.asarray(Lab_b, dtype=np.float64), -1, 0)
    c_bar = 0.5 * (np.hypot(a1, b1) + np.hypot(a2, b2))
    c7 = c_bar ** 7
    g = 0.5 * (1.0 - np.sqrt(c7 / (c7 + 25.0 ** 7)))                      # eq. 4
    a1p, a2p = (1.0 + g) * a1, (1.0 + g) * a2                             # eq. 5
    c1p, c2p = np.hypot(a1p, b1), np.hypot(a2p, b2)                       # eq. 6
    h1p = np.degrees(np.arctan2(b1, a1p)) % 360.0                         # eq. 7
    h2p = np.degrees(np.arctan2(b2, a2p)) % 360.0
    h1p = np.where((a1p == 0) & (b1 == 0), 0.0, h1p)
    h2p = np.where((a2p == 0) & (b2 == 0), 0.0, h2p)
    zero = c1p * c2p == 0
    dh = h2p - h1p                                                        # eq. 10
    dh = np.where(dh > 180.0, dh - 360.0, np.where(dh < -180.0, dh + 360.0, dh))
    dh = np.where(zero, 0.0, dh)
    dL, dC = L2 - L1, c2p - c1p                                           # eq. 8, 9
    dH = 2.0 * np.sqrt(c1p * c2p) * np.sin(np.radians(0.5 * dh))          # eq. 11
    L_bar, C_bar = 0.5 * (L1 + L2), 0.5 * (c1p + c2p)                     # eq. 12, 13
    h_sum = h1p + h2p                                                     # eq. 14
    h_bar = np.where(np.abs(h1p - h2p) <= 180.0, 0.5 * h_sum,
                     np.where(h_sum < 360.0, 0.5 * (h_sum + 360.0), 0.5 * (h_sum - 360.0)))
    h_bar = np.where(zero, h_sum, h_bar)
    t = (1.0 - 0.17 * np.cos(np.radians(h_bar - 30.0)) + 0.24 * np.cos(np.radians(2.0 * h_bar))
         + 0.32 * np.cos(np.radians(3.0 * h_bar + 6.0)) - 0.20 * np.cos(np.radians(4.0 * h_bar - 63.0)))  # eq. 15
    d_theta = 30.0 * np.exp(-(((h_bar - 275.0) / 25.0) ** 2))             # eq. 16
    c_bar7 = C_bar ** 7
    r_c = 2.0 * np.sqrt(c_bar7 / (c_bar7 + 25.0 ** 7))                    # eq. 17
    l50 = (L_bar - 50.0) ** 2
    s_l = 1.0 + 0.015 * l50 / np.sqrt(20.0 + l50)                         # eq. 18
    s_c = 1.0 + 0.045 * C_bar                                             # eq. 19
    s_h = 1.0 + 0.015 * C_bar * t                                         # eq. 20
    r_t = -np.sin(np.radians(2.0 * d_theta)) * r_c                        # eq. 21
    tl, tc, th = dL / s_l, dC / s_c, dH / s_h
    return np.sqrt(tl * tl + tc * tc + th * th + r_t * tc * th)          # eq. 22


def RGB_to_Lab(rgb, colour_space="lin_rec709") -> np.ndarray:
    """CIELAB of linear working RGB: :func:`RGB_to_XYZ` then :func:`XYZ_to_Lab`."""
    return XYZ_to_Lab(RGB_to_XYZ(rgb, colour_space))


def srgb_encode(linear) -> np.ndarray:
    """sRGB OETF (IEC 61966-2-1:1999, eq. 5): ``12.92 L`` for L <= 0.0031308, else ``1.055 L^(1/2.4) - 0.055``.
    Values below 0 are not clipped (the linear segment continues)."""
    x = np.asarray(linear, dtype=np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0.0031308), 1.0 / 2.4) - 0.055)


def srgb_decode(encoded) -> np.ndarray:
    """Inverse of :func:`srgb_encode` (IEC 61966-2-1:1999, eq. 2): ``V / 12.92`` at or below the encoded break
    point ``12.92 * 0.0031308`` (= 0.04044994; the standard rounds it to 0.04045, colour-science uses this
    exact one, and no 8-bit value lies between them), else ``((V + 0.055) / 1.055)^2.4``."""
    v = np.asarray(encoded, dtype=np.float64)
    knee = 12.92 * 0.0031308
    return np.where(v <= knee, v / 12.92, np.power((np.maximum(v, knee) + 0.055) / 1.055, 2.4))


def linear_to_srgb8(rgb) -> np.ndarray:
    """(..., 3) linear lin_rec709 -> (..., 3) uint8: sRGB OETF (IEC 61966-2-1) of the value clipped to [0, 1].

    This is docs/design.md's display transform, for GL renders, reference renders and the textures alike, so
    their PNGs are comparable. (``rockdove.spectral.RGB_to_preview8`` desaturates out-of-gamut colours
    instead of clipping them; it is not used here.) NaN shows as black, +inf as 1.

    The code of a value is ``round(255 * srgb_encode(clip(v, 0, 1)))``. That is a non-decreasing step function
    of ``v`` with 255 steps (:func:`_srgb8_steps`, found once by bisection on that very formula), at least
    3e-4 apart. So [0, 1] is cut into :data:`_SRGB8_CELLS` equal cells, each holding at most one step
    (:func:`_srgb8_cells`), and a value's code is its cell's code at the cell's start, plus one if the value is
    at or above the step inside the cell: a multiply, a cast and two table look-ups per value, with no power
    and no search, giving the same codes as the formula for every float64 and float32. float32 images are
    read as they are (with their own table of steps), not copied to float64. Done in blocks that stay in the
    cache. A 1024 x 1024 x 3 image (uniform in [-0.05, 1.1]), median of 5 runs alternating with the former
    binary search among the steps, in one process on 2 shared cores: float64 0.197 s -> 0.023 s (8.7x),
    float32 0.212 s -> 0.024 s (9.0x).
    """
    rgb = np.asarray(rgb)
    if rgb.dtype != np.float32:
        rgb = np.asarray(rgb, dtype=np.float64)
    code_at, step = _srgb8_cells(rgb.dtype)
    flat = rgb.reshape(-1)
    out = np.empty(flat.shape, np.uint8)
    block = max(1, min(_SRGB8_BLOCK, flat.size))
    scaled = np.empty(block, rgb.dtype)
    cell = np.empty(block, np.intp)
    step_of = np.empty(block, rgb.dtype)
    above = np.empty(block, bool)
    with np.errstate(over="ignore"):
        for start in range(0, flat.size, block):
            v = flat[start:start + block]
            n = v.size
            x, c, s, a, o = scaled[:n], cell[:n], step_of[:n], above[:n], out[start:start + n]
            np.multiply(v, _SRGB8_CELLS, out=x)  # exact (a power of two); beyond the float range: inf
            np.fmax(x, 0, out=x)  # NaN, -inf and negatives -> cell 0 (NaN then never compares >= a step)
            np.fmin(x, _SRGB8_CELLS - 1, out=x)  # 1, above 1 and +inf -> the last cell
            c[...] = x  # truncation = floor (x >= 0)
            code_at.take(c, out=o, mode="clip")
            step.take(c, out=s, mode="clip")
            np.greater_equal(v, s, out=a)  # False against NaN, the step of a cell without one
            np.add(o, a, out=o)
    return out.reshape(rgb.shape)


_SRGB8_CELLS = 1 << 14  # cells over [0, 1]: 6.1e-5 wide, 5 times narrower than the closest two steps
_SRGB8_BLOCK = 1 << 16  # values per block of linear_to_srgb8 (its scratch arrays stay in the cache)


@lru_cache(maxsize=2)
def _srgb8_cells(dtype) -> tuple[np.ndarray, np.ndarray]:
    """(code_at, step), each (_SRGB8_CELLS,), for :func:`linear_to_srgb8` on ``dtype`` (float64 or float32)
    values. Cell ``c`` holds the values in ``[c, c + 1) / _SRGB8_CELLS``; ``code_at[c]`` is the code at its
    start (the number of steps at or below it), ``step[c]`` the one step strictly inside it, NaN if none.
    For float32 the steps are the smallest float32s at or above the float64 steps, so that comparing a float32
    with them is comparing its exact float64 value with the float64 steps."""
    steps = _srgb8_steps()
    if np.dtype(dtype) == np.float32:
        steps32 = steps.astype(np.float32)
        steps32 = np.where(steps32.astype(np.float64) < steps, np.nextafter(steps32, np.float32(2.0)), steps32)
        steps = steps32.astype(np.float64)
    edges = np.arange(_SRGB8_CELLS + 1, dtype=np.float64) / _SRGB8_CELLS
    code_at = np.searchsorted(steps, edges[:-1], side="right")
    inside = np.searchsorted(steps, edges[1:], side="left") - code_at
    if inside.max() > 1:  # a property of the sRGB curve and _SRGB8_CELLS
        raise AssertionError("two sRGB 8-bit steps in one cell; use more cells")
    step = np.full(_SRGB8_CELLS, np.nan, dtype)
    step[inside == 1] = steps[code_at[inside == 1]]
    code_at = code_at.astype(np.uint8)
    code_at.setflags(write=False)
    step.setflags(write=False)
    return code_at, step


def _srgb8_code(v) -> np.ndarray:
    """The 8-bit code of linear values by the formula itself (:func:`linear_to_srgb8`'s definition)."""
    return np.round(np.clip(srgb_encode(np.clip(v, 0.0, 1.0)), 0.0, 1.0) * 255.0)


@lru_cache(maxsize=1)
def _srgb8_steps() -> np.ndarray:
    """(255,) float64: entry k - 1 is the smallest linear value whose code is >= k. Bisection over the ordered
    bit patterns of the non-negative float64s in [0, 1], so each step is exact to the last bit."""
    lo = np.zeros(255, np.int64)  # code(lo) < k
    hi = np.full(255, np.float64(1.0).view(np.int64))  # code(hi) >= k
    k = np.arange(1, 256)
    while np.any(hi - lo > 1):
        mid = lo + (hi - lo) // 2
        above = _srgb8_code(mid.view(np.float64)) >= k
        hi, lo = np.where(above, mid, hi), np.where(above, lo, mid)
    steps = hi.view(np.float64)
    steps.setflags(write=False)
    return steps


def RGB_to_preview8(rgb, colour_space="lin_rec709") -> np.ndarray:
    """8-bit sRGB preview of linear working RGB, for people (PNG previews), not for data.

    Mapping, per colour:

    1. convert to linear Rec.709 (sRGB primaries) if ``colour_space`` differs;
    2. out of gamut (a negative component): desaturate toward the colour's own Rec.709 luminance
       Y = 0.2126 R + 0.7152 G + 0.0722 B, by the least amount that makes every component >= 0, i.e.
       ``Y + s (rgb - Y)`` with ``s = Y / (Y - min(rgb))``. Hue and luminance are kept, saturation drops;
       a colour with Y <= 0 becomes black;
    3. over range: clip each component to 1 (highlights may shift hue, as in most displays);
    4. sRGB OETF (IEC 61966-2-1, :func:`srgb_encode`), round to 0-255.

    Parameters
    ----------
    rgb : array_like, (..., 3), linear
    colour_space : one of :data:`COLOUR_SPACES`

    Returns
    -------
    ndarray, (..., 3), uint8
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.shape[-1:] != (3,):
        raise ValueError(f"rgb must have a trailing axis of 3, got shape {rgb.shape}")
    if not np.all(np.isfinite(rgb)):
        raise ValueError("rgb must be finite (got NaN or inf)")
    if check_colour_space(colour_space) != "lin_rec709":
        rgb = XYZ_to_RGB(RGB_to_XYZ(rgb, colour_space), "lin_rec709")
    lum = (rgb @ _rec709_luminance())[..., None]
    low = rgb.min(axis=-1, keepdims=True)
    neg = low < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(neg & (lum > 0), lum / (lum - low), 1.0)
    mapped = np.where(neg, np.where(lum > 0, lum + s * (rgb - lum), 0.0), rgb)
    mapped = np.clip(mapped, 0.0, 1.0)
    encoded = srgb_encode(mapped)
    return np.round(np.clip(encoded, 0.0, 1.0) * 255.0).astype(np.uint8)
