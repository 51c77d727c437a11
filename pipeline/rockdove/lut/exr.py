"""OpenEXR I/O of a :class:`~rockdove.lut.table.ThinFilmLUT` (docs/design.md, "ThinFilmLUT").

File layout
-----------
RGB, one scanline image, width ``n_angle``, height ``n_thickness``; FLOAT (32-bit) channels, or HALF (16-bit)
ones when written with ``precision="half"`` (about half the file; the values are those of ``rgb`` rounded to
the nearest half float, which :func:`read_exr` returns as float32, exactly). The *bottom* image row is the
thinnest film (``rgb[0]``), matching USD's ``st`` (t = 0 at the bottom), so the image array written is
``rgb[::-1]``. ZIP compression (lossless). Header string attributes, all prefixed ``rockdove:`` (docs/design.md,
"ThinFilmLUT"): ``format`` = :data:`FORMAT_TAG` (:func:`read_exr` refuses files without it), ``angleAxis``,
``angleWarpGamma`` and ``thicknessRangeNm`` (``repr`` of the floats: they round-trip exactly), ``colourSpace``,
``precision`` (the channel type) and every entry of ``lut.metadata`` as ``rockdove:<key>``.

Determinism: OpenEXR 3.x's Python API writes only the attributes it is given plus the required ones
(channels, compression, windows, line order, pixel aspect, screen window); no timestamp or host name. The
attributes are written sorted by name and the pixels are contiguous arrays (OpenEXR 3.x writes strided
views wrongly), so the same LUT gives byte-identical files (tested)."""

from __future__ import annotations

import os

import numpy as np

from ..errors import UsageError
from .table import ThinFilmLUT

PREFIX = "rockdove:"
FORMAT_TAG = "ThinFilmLUT 1"
ANGLE_AXIS = "cos_theta = x**gamma, x = j/(N-1)"
_RESERVED = ("format", "angleAxis", "angleWarpGamma", "thicknessRangeNm", "colourSpace", "precision")
#: precision name -> numpy dtype of the EXR channels (OpenEXR's Python API takes the channel type from the dtype)
PRECISIONS = {"float32": np.float32, "half": np.float16}


def write_exr(lut: ThinFilmLUT, path, precision: str | None = None) -> str:
    """Write ``lut`` as an RGB OpenEXR file (FLOAT or HALF channels) with its axes and provenance in the header;
    returns ``path`` as a string. Written directly (``rockdove lut`` writes a temporary name and replaces).
    ``precision`` ("float32" or "half"): default ``lut.metadata["precision"]`` when the LUT carries one (the build's
    ``lut.precision = "half"`` rounds its values and records it there), else "float32"; "half" rounds to the
    nearest half float (values beyond +-65504 become inf)."""
    import OpenEXR

    if not isinstance(lut, ThinFilmLUT):
        raise UsageError(f"lut must be a ThinFilmLUT, got {type(lut).__name__}")
    if precision is None:
        precision = str(lut.metadata.get("precision", "float32"))
    if precision not in PRECISIONS:
        raise UsageError(f"precision={precision!r} is not an EXR channel type; allowed: {sorted(PRECISIONS)}")
    path = os.fspath(path)
    pixels = np.ascontiguousarray(lut.rgb[::-1], dtype=PRECISIONS[precision])  # bottom row = thinnest
    lo, hi = lut.thickness_range_nm
    attrs = {"precision": precision, "format": FORMAT_TAG, "angleAxis": ANGLE_AXIS,
             "angleWarpGamma": repr(float(lut.angle_warp_gamma)), "thicknessRangeNm": f"{float(lo)!r} {float(hi)!r}",
             "colourSpace": str(lut.colour_space)}
    attrs.update({str(key): str(value) for key, value in lut.metadata.items() if key not in _RESERVED})
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
              **{PREFIX + k: attrs[k] for k in sorted(attrs)}}
    with OpenEXR.File(header, {"RGB": pixels}) as f:
        f.write(path)
    return path


def read_exr(path) -> ThinFilmLUT:
    """Read a LUT written by :func:`write_exr`: the same ``rgb`` (bit exact; HALF channels widened to float32
    exactly), axes, colour space and metadata, ``metadata["precision"]`` the channel type. FileNotFoundError when
    ``path`` does not exist; UsageError (a ValueError) when it is not an OpenEXR file or not a rockdove LUT (no
    ``rockdove:format`` attribute, missing axis attributes, or no FLOAT/HALF RGB channels)."""
    import OpenEXR

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"path: no such LUT file: {path!r}")
    with open(path, "rb") as fh:
        magic = fh.read(4)
    if magic != b"\x76\x2f\x31\x01":
        raise UsageError(f"path: {path!r} is not an OpenEXR file (bad magic number)")
    try:
        with OpenEXR.File(path) as f:
            header = dict(f.header())
            channels = {name: np.array(ch.pixels) for name, ch in f.channels().items()}
    except Exception as exc:  # OpenEXR raises RuntimeError/OSError on damaged files
        raise UsageError(f"path: {path!r} is not a readable OpenEXR file ({exc})") from exc
    if header.get(PREFIX + "format") != FORMAT_TAG:
        raise UsageError(f"path: {path!r} is an OpenEXR file but not a rockdove LUT "
                         f"(header attribute {PREFIX}format = {FORMAT_TAG!r} missing)")
    missing = [k for k in ("angleWarpGamma", "thicknessRangeNm", "colourSpace") if PREFIX + k not in header]
    if missing:
        raise UsageError(f"path: {path!r} lacks header attributes {[PREFIX + k for k in missing]}")
    if "RGB" in channels:
        rgb = channels["RGB"]
    elif all(c in channels for c in "RGB"):
        rgb = np.stack([channels[c] for c in "RGB"], axis=-1)
    else:
        raise UsageError(f"path: {path!r} has channels {sorted(channels)}, expected R, G, B")
    if rgb.dtype not in (np.float32, np.float16) or rgb.ndim != 3 or rgb.shape[2] != 3:
        raise UsageError(f"path: {path!r} must hold float32 or half RGB, got {rgb.dtype} {rgb.shape}")
    channel_precision = "half" if rgb.dtype == np.float16 else "float32"
    recorded = header.get(PREFIX + "precision")
    if recorded is not None and recorded != channel_precision:
        raise UsageError(f"path: {path!r} records {PREFIX}precision = {recorded!r} but holds {channel_precision} "
                         "channels")
    try:
        gamma = float(header[PREFIX + "angleWarpGamma"])
        lo, hi = (float(v) for v in str(header[PREFIX + "thicknessRangeNm"]).split())
    except ValueError as exc:
        raise UsageError(f"path: {path!r} has malformed axis attributes ({exc})") from exc
    metadata = {k[len(PREFIX):]: str(v) for k, v in header.items()
                if isinstance(k, str) and k.startswith(PREFIX) and k[len(PREFIX):] not in _RESERVED}
    if channel_precision == "half" or recorded is not None:
        metadata["precision"] = channel_precision
    return ThinFilmLUT(np.ascontiguousarray(rgb[::-1], dtype=np.float32), (lo, hi), angle_warp_gamma=gamma,
                       colour_space=str(header[PREFIX + "colourSpace"]), metadata=metadata)
