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

CIELAB uses the same reference white at Y = 1; CIEDE2000 is colour-science's ``delta_E(..., "CIE 2000")``
(Sharma, Wu and Dalal 2005).
"""

from __future__ import annotations

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


@lru_cache(maxsize=8)
def _tables(illuminant: str, observer: str):
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
    cw = np.array(cmfs.wavelengths, dtype=np.float64)
    cv = np.array(cmfs.values, dtype=np.float64)
    sw = np.array(sd.wavelengths, dtype=np.float64)
    sv = np.array(sd.values, dtype=np.float64)
    for a in (cw, cv, sw, sv):
        a.setflags(write=False)
    return cw, cv, sw, sv


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
    """(3, 3) matrix M with ``rgb = XYZ @ M`` (row vectors), built with colour.XYZ_to_RGB."""
    colour = _colour()
    check_colour_space(colour_space)
    m = colour.XYZ_to_RGB(
        np.eye(3),
        colour.RGB_COLOURSPACES[_COLOURSPACE_NAMES[colour_space]],
        illuminant=reference_white_xy(),
        chromatic_adaptation_transform=CHROMATIC_ADAPTATION,
        apply_cctf_encoding=False,
    )
    m = np.array(m, dtype=np.float64)
    m.setflags(write=False)
    return m


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


def XYZ_to_Lab(XYZ) -> np.ndarray:
    """CIELAB (L in [0, 100]) of XYZ with the reference D65 white at Y = 1. (..., 3) -> (..., 3)."""
    colour = _colour()
    return np.asarray(colour.XYZ_to_Lab(np.asarray(XYZ, dtype=np.float64), illuminant=reference_white_xy()))


def delta_E_2000(Lab_a, Lab_b) -> np.ndarray:
    """CIEDE2000 colour difference (colour-science, method "CIE 2000"); (..., 3), (..., 3) -> (...)."""
    colour = _colour()
    return np.asarray(colour.delta_E(np.asarray(Lab_a, float), np.asarray(Lab_b, float), method="CIE 2000"))


def RGB_to_Lab(rgb, colour_space="lin_rec709") -> np.ndarray:
    """CIELAB of linear working RGB: :func:`RGB_to_XYZ` then :func:`XYZ_to_Lab`."""
    return XYZ_to_Lab(RGB_to_XYZ(rgb, colour_space))


def linear_to_srgb8(rgb) -> np.ndarray:
    """(..., 3) linear lin_rec709 -> (..., 3) uint8: sRGB OETF (IEC 61966-2-1) of the value clipped to [0, 1].

    This is docs/design.md's display transform, for GL renders, reference renders and the textures alike, so
    their PNGs are comparable. (``pipeline.spectral.RGB_to_preview8`` desaturates out-of-gamut colours
    instead of clipping them; it is not used here.) NaN shows as black, +inf as 1.
    """
    from ._compat import import_colour

    colour = import_colour()

    rgb = np.nan_to_num(np.asarray(rgb, dtype=np.float64), nan=0.0, posinf=1.0, neginf=0.0)
    enc = colour.cctf_encoding(np.clip(rgb, 0.0, 1.0), function="sRGB")
    return np.round(np.clip(enc, 0.0, 1.0) * 255.0).astype(np.uint8)


def RGB_to_preview8(rgb, colour_space="lin_rec709") -> np.ndarray:
    """8-bit sRGB preview of linear working RGB, for people (PNG previews), not for data.

    Mapping, per colour:

    1. convert to linear Rec.709 (sRGB primaries) if ``colour_space`` differs;
    2. out of gamut (a negative component): desaturate toward the colour's own Rec.709 luminance
       Y = 0.2126 R + 0.7152 G + 0.0722 B, by the least amount that makes every component >= 0, i.e.
       ``Y + s (rgb - Y)`` with ``s = Y / (Y - min(rgb))``. Hue and luminance are kept, saturation drops;
       a colour with Y <= 0 becomes black;
    3. over range: clip each component to 1 (highlights may shift hue, as in most displays);
    4. sRGB OETF (IEC 61966-2-1, colour-science's ``cctf_encoding(..., "sRGB")``), round to 0-255.

    Parameters
    ----------
    rgb : array_like, (..., 3), linear
    colour_space : one of :data:`COLOUR_SPACES`

    Returns
    -------
    ndarray, (..., 3), uint8
    """
    colour = _colour()
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.shape[-1:] != (3,):
        raise ValueError(f"rgb must have a trailing axis of 3, got shape {rgb.shape}")
    if not np.all(np.isfinite(rgb)):
        raise ValueError("rgb must be finite (got NaN or inf)")
    if check_colour_space(colour_space) != "lin_rec709":
        rgb = XYZ_to_RGB(RGB_to_XYZ(rgb, colour_space), "lin_rec709")
    weights = np.asarray(colour.RGB_COLOURSPACES["ITU-R BT.709"].matrix_RGB_to_XYZ)[1]
    lum = (rgb @ weights)[..., None]
    low = rgb.min(axis=-1, keepdims=True)
    neg = low < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(neg & (lum > 0), lum / (lum - low), 1.0)
    mapped = np.where(neg, np.where(lum > 0, lum + s * (rgb - lum), 0.0), rgb)
    mapped = np.clip(mapped, 0.0, 1.0)
    encoded = np.asarray(colour.cctf_encoding(mapped, function="sRGB"))
    return np.round(np.clip(encoded, 0.0, 1.0) * 255.0).astype(np.uint8)
