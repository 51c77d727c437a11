"""Spectral colour: reflectance spectrum -> CIE XYZ (D65, CIE 1931 2 deg) -> working RGB; CIELAB and dE2000.

Data: colour-science's CIE 1931 2 deg colour-matching functions (1 nm, 360-830 nm) and CIE D65 (5 nm, 300-780 nm)
(``colour.MSDS_CMFS``, ``colour.SDS_ILLUMINANTS``), linearly interpolated; the domain is
:data:`WAVELENGTH_RANGE_NM` = 360-780 nm, where both are defined.

Normalisation (CIE 15:2004, sec. 7.1, k such that a perfect reflector has Y = 1), with trapezoid weights ``w_i``
on the given, possibly non-uniform, strictly increasing grid:

    X = sum_i w_i R_i S_i xbar_i / sum_i w_i S_i ybar_i     (likewise Y, Z)

Working colour spaces (MaterialX names): ``lin_rec709`` (BT.709 primaries, D65 white) and ``acescg`` (AP1, ~D60),
by colour-science's RGB colourspace matrices and a Bradford adaptation (as MaterialX's ``lin_rec709_to_acescg``)
from the reference white: the D65 table itself integrated on the 1 nm grid over 360-780 nm (x, y = 0.31272,
0.32903), so a perfect reflector is exactly (1, 1, 1) in ``lin_rec709`` (the rounded (0.3127, 0.3290) is ~1e-4
off). Results are not clipped: thin-film colours are often out of gamut.

CIELAB (CIE 15:2004, eq. 8.1-8.3, exact constants 216/24389 and 24389/27) uses the same white at Y = 1; CIEDE2000
follows Sharma, Wu and Dalal (2005), eq. 1-24; both are tested against colour-science (tests/test_spectral.py).
The sRGB transfer functions and the 8-bit display encoding are :mod:`rockdove.srgb`'s.

Importing colour-science takes ~1 s, far more than a LUT bake, and only its data are used: they are read once and
kept as ``.npz`` in ``$XDG_CACHE_HOME/rockdove/colour-science-<key>/``, keyed by the code that computes them, the
installed distributions and Python (:func:`colour_data`, :func:`rockdove.sources.cache_dir`), so a film-only
rebuild never imports it. An unwritable folder means recomputing per process."""

from __future__ import annotations

import contextlib
import zipfile
from functools import lru_cache

import numpy as np

from ._compat import import_colour  # colour-science (~1 s to import) is imported by the functions that need it
from .errors import UsageError
from .srgb import srgb_encode

WAVELENGTH_RANGE_NM = (360.0, 780.0)
DEFAULT_ILLUMINANT = "D65"
DEFAULT_OBSERVER = "CIE 1931 2 Degree Standard Observer"
COLOUR_SPACES = ("lin_rec709", "acescg")
# MaterialX colour space name -> colour-science RGB colourspace name.
_COLOURSPACE_NAMES = {"lin_rec709": "ITU-R BT.709", "acescg": "ACEScg"}
CHROMATIC_ADAPTATION = "Bradford"  # as MaterialX's lin_rec709 <-> acescg matrices
_REFERENCE_STEP_NM = 1.0  # grid of the reference white (the CMFS table's own step)


def _check_wavelengths(wavelength_nm) -> np.ndarray:
    try:
        lam = np.asarray(wavelength_nm, dtype=np.float64)
    except (TypeError, ValueError):
        raise UsageError(f"wavelength_nm must be real numbers, got {wavelength_nm!r}") from None
    lo, hi = WAVELENGTH_RANGE_NM
    if lam.size and not (lam.min() >= lo and lam.max() <= hi):
        bad = lam[~((lam >= lo) & (lam <= hi))].flat[0].item()
        raise UsageError(f"wavelength_nm must be within [{lo:g}, {hi:g}] nm (colour's D65 table ends at 780), got {bad!r}")
    return lam


def colour_data(name: str, compute, keys: tuple[str, ...]) -> dict:
    """Read-only arrays derived from colour-science's data, from ``<name>.npz`` in the cache (module docstring);
    ``compute()`` (which may import colour-science) builds them where the file is missing, torn or lacks one of
    ``keys``. ``name`` must be unique per content."""
    import io

    from .resources import load_npz, write_cached
    from .sources import cache_dir

    path = cache_dir("colour-science", compute) / f"{name}.npz"
    with contextlib.suppress(OSError, ValueError, EOFError, zipfile.BadZipFile):  # missing, or torn by a crash
        arrays = load_npz(path)
        if set(keys) <= set(arrays):  # else written by another layout of the same name: rebuilt below
            return arrays
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
        colour = import_colour()
        if observer not in colour.MSDS_CMFS:
            raise UsageError(f"observer must be one of colour.MSDS_CMFS (e.g. {DEFAULT_OBSERVER!r}), got {observer!r}")
        if illuminant not in colour.SDS_ILLUMINANTS:
            raise UsageError(f"illuminant must be one of colour.SDS_ILLUMINANTS (e.g. 'D65'), got {illuminant!r}")
        cmfs = colour.MSDS_CMFS[observer]
        sd = colour.SDS_ILLUMINANTS[illuminant]
        lo, hi = WAVELENGTH_RANGE_NM
        for what, table in (("observer", cmfs), ("illuminant", sd)):
            if table.wavelengths[0] > lo or table.wavelengths[-1] < hi:
                raise UsageError(f"{what} {table.name!r} does not cover {lo:g}-{hi:g} nm")
        return dict(zip(keys, (cmfs.wavelengths, cmfs.values, sd.wavelengths, sd.values)))

    keys = ("cmfs_wavelength_nm", "cmfs", "illuminant_wavelength_nm", "illuminant")
    slug = "".join(c if c.isalnum() or c in "-." else "_" for c in f"{illuminant}-{observer}")
    t = colour_data(f"tables-{slug}", compute, keys)
    return tuple(t[k] for k in keys)


def cmfs_illuminant(wavelength_nm, illuminant=DEFAULT_ILLUMINANT, observer=DEFAULT_OBSERVER):
    """``(cmfs, S)`` linearly interpolated at ``wavelength_nm`` (N,) nm: xbar, ybar, zbar (N, 3) of the observer
    (a key of ``colour.MSDS_CMFS``) and the relative power (N,) of the illuminant (of ``colour.SDS_ILLUMINANTS``;
    colour's scale, S(560) = 100 for D65)."""
    lam = _check_wavelengths(wavelength_nm)
    cw, cv, sw, sv = _tables(illuminant, observer)
    cmfs = np.stack([np.interp(lam, cw, cv[:, k]) for k in range(3)], axis=-1)
    return cmfs, np.interp(lam, sw, sv)


def spectral_weights(wavelength_nm, illuminant=DEFAULT_ILLUMINANT, colour_space=None) -> np.ndarray:
    """Weights W (N, 3) with ``XYZ = R @ W`` (or working RGB, with ``colour_space``) for a reflectance sampled on
    ``wavelength_nm`` (N >= 2, strictly increasing): ``W[i] = w_i S_i cmf_i / sum_j w_j S_j ybar_j`` with
    trapezoid weights w, so R = 1 gives Y = 1 exactly on any grid."""
    lam = _check_wavelengths(wavelength_nm)
    if lam.ndim != 1 or lam.size < 2:
        raise UsageError(f"wavelength_nm must be a 1-D grid of at least 2 wavelengths, got shape {lam.shape}")
    if not np.all(np.diff(lam) > 0):
        raise UsageError("wavelength_nm must be strictly increasing")
    cmfs, s = cmfs_illuminant(lam, illuminant)
    ws = np.convolve(np.diff(lam), (0.5, 0.5)) * s  # trapezoid weights: half of each interval to either end
    weights = cmfs * ws[:, None] / np.dot(ws, cmfs[:, 1])
    if colour_space is not None:
        weights = weights @ _xyz_to_rgb_matrix_t(colour_space)
    return weights


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
        raise UsageError(f"colour_space must be one of {COLOUR_SPACES}, got {colour_space!r}")
    return colour_space


@lru_cache(maxsize=4)
def _xyz_to_rgb_matrix_t(colour_space: str) -> np.ndarray:
    """(3, 3) matrix M with ``rgb = XYZ @ M`` (row vectors), built with colour.XYZ_to_RGB (cached on disk)."""
    check_colour_space(colour_space)
    white = reference_white_xy()

    def compute() -> dict:
        colour = import_colour()
        return {"matrix": colour.XYZ_to_RGB(np.eye(3), colour.RGB_COLOURSPACES[_COLOURSPACE_NAMES[colour_space]],
                                            illuminant=white, chromatic_adaptation_transform=CHROMATIC_ADAPTATION,
                                            apply_cctf_encoding=False)}

    # the white is derived from the tables; naming the file by it keeps a matrix from outliving its white
    return colour_data(f"xyz-to-{colour_space}-{CHROMATIC_ADAPTATION}-{white[0]:.15f}-{white[1]:.15f}",
                       compute, ("matrix",))["matrix"]


@lru_cache(maxsize=1)
def _rec709_luminance() -> np.ndarray:
    """Y row of ITU-R BT.709's RGB -> XYZ matrix (colour-science's), (3,): Y = rgb @ weights."""
    def compute() -> dict:
        return {"weights": np.asarray(import_colour().RGB_COLOURSPACES["ITU-R BT.709"].matrix_RGB_to_XYZ)[1]}

    return colour_data("rec709-luminance", compute, ("weights",))["weights"]


def XYZ_to_RGB(XYZ, colour_space="lin_rec709") -> np.ndarray:
    """Linear working RGB (..., 3), unclipped, of CIE XYZ (..., 3) (the reference white at Y = 1 -> (1, 1, 1) in
    lin_rec709)."""
    return np.asarray(XYZ, dtype=np.float64) @ _xyz_to_rgb_matrix_t(check_colour_space(colour_space))


def RGB_to_XYZ(RGB, colour_space="lin_rec709") -> np.ndarray:
    """Inverse of :func:`XYZ_to_RGB`: (..., 3) linear RGB -> (..., 3) CIE XYZ."""
    return np.asarray(RGB, dtype=np.float64) @ np.linalg.inv(_xyz_to_rgb_matrix_t(check_colour_space(colour_space)))


#: CIE 15:2004 CIELAB constants, exact rationals: epsilon = (6/29)^3, kappa = (29/3)^3.
_LAB_EPSILON = 216.0 / 24389.0
_LAB_KAPPA = 24389.0 / 27.0


def _lab_white() -> np.ndarray:
    """XYZ (Yn = 1) of the reference white, from its chromaticity."""
    xy = reference_white_xy()
    return np.array([xy[0] / xy[1], 1.0, (1.0 - xy[0] - xy[1]) / xy[1]])


def XYZ_to_Lab(XYZ) -> np.ndarray:
    """CIELAB (..., 3) of XYZ (..., 3), the reference white at Y = 1 (CIE 15:2004 eq. 8.1-8.3): ``f(t) = t^(1/3)``
    above epsilon, ``(kappa t + 16) / 116`` below; ``L = 116 f(Y/Yn) - 16``, ``a = 500 (f(X/Xn) - f(Y/Yn))``,
    ``b = 200 (f(Y/Yn) - f(Z/Zn))``."""
    t = np.asarray(XYZ, dtype=np.float64) / _lab_white()
    f = np.where(t > _LAB_EPSILON, np.cbrt(t), (_LAB_KAPPA * t + 16.0) / 116.0)
    return np.stack([116.0 * f[..., 1] - 16.0, 500.0 * (f[..., 0] - f[..., 1]), 200.0 * (f[..., 1] - f[..., 2])],
                    axis=-1)


def Lab_to_XYZ(Lab) -> np.ndarray:
    """Inverse of :func:`XYZ_to_Lab` (CIE 15:2004 eq. 8.4-8.6, the same white). (..., 3) -> (..., 3)."""
    lab = np.asarray(Lab, dtype=np.float64)
    fy = (lab[..., 0] + 16.0) / 116.0
    f = np.stack([fy + lab[..., 1] / 500.0, fy, fy - lab[..., 2] / 200.0], axis=-1)
    t = np.where(f ** 3 > _LAB_EPSILON, f ** 3, (116.0 * f - 16.0) / _LAB_KAPPA)
    return t * _lab_white()


def delta_E_2000(Lab_a, Lab_b) -> np.ndarray:
    """CIEDE2000 colour difference (...) of two CIELAB arrays (..., 3), k_L = k_C = k_H = 1: Sharma, Wu and Dalal
    (2005), "The CIEDE2000 color-difference formula: implementation notes, supplementary test data, and
    mathematical observations", Color Res. Appl. 30(1), eq. 1-24 (hue angles in degrees; h' = 0 where a' = b' = 0)."""
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


def RGB_to_preview8(rgb, colour_space="lin_rec709") -> np.ndarray:
    """8-bit sRGB preview (..., 3) uint8 of linear working RGB (..., 3), for people (PNG previews), not for data. Per
    colour: convert to linear Rec.709; out of gamut (a negative component), desaturate toward its own Rec.709 luminance
    Y = 0.2126 R + 0.7152 G + 0.0722 B by the least amount that makes every component >= 0, ``Y + s (rgb - Y)`` with
    ``s = Y / (Y - min(rgb))`` (hue and luminance kept; Y <= 0 becomes black); clip to 1; sRGB OETF (IEC 61966-2-1,
    :func:`srgb_encode`), round to 0-255."""
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.shape[-1:] != (3,):
        raise UsageError(f"rgb must have a trailing axis of 3, got shape {rgb.shape}")
    if not np.all(np.isfinite(rgb)):
        raise UsageError("rgb must be finite (got NaN or inf)")
    if check_colour_space(colour_space) != "lin_rec709":
        rgb = XYZ_to_RGB(RGB_to_XYZ(rgb, colour_space), "lin_rec709")
    lum = (rgb @ _rec709_luminance())[..., None]
    low = rgb.min(axis=-1, keepdims=True)
    neg = low < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(neg & (lum > 0), lum / (lum - low), 1.0)
    mapped = np.where(neg, np.where(lum > 0, lum + s * (rgb - lum), 0.0), rgb)
    return np.round(np.clip(srgb_encode(np.clip(mapped, 0.0, 1.0)), 0.0, 1.0) * 255.0).astype(np.uint8)
