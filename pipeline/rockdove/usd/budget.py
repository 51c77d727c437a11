"""Size budgets a layer must meet before USD opens it, from a scan of its bytes (no parse, no composition): a
crate file's table of contents and the element count that heads each array; a text layer's size and prim
statements; a texture's header; then, while :mod:`rockdove.usd.dependencies` walks the opened layer, the largest
face. Where each limit comes from (measured): docs/hostile-input.md, "Size budgets"."""

from __future__ import annotations

import contextlib
import mmap
import re
import struct

MAX_SPECS = 100_000
MAX_ARRAY = 1 << 24
MAX_FACE = 1024
MAX_TEXT_BYTES = 64 << 20
MAX_TEXELS = 4096 * 4096
_PRIM = re.compile(rb"(?m)^[ \t]*(?:def|over|class)\b")


def _lz4(src: bytes, size: int) -> bytes:
    """At most ``size`` bytes of an LZ4 block (crate sections use it through TfFastCompression)."""
    out, i = bytearray(), 0

    def more(n):  # a length nibble of 15 goes on in bytes while they are 255
        nonlocal i
        go = n == 15
        while go:
            n, i, go = n + src[i], i + 1, src[i] == 255
        return n
    while i < len(src) and len(out) < size:
        token = src[i]
        i += 1
        lit = more(token >> 4)
        out += src[i:i + lit]
        i += lit
        if i >= len(src):
            break
        off, i = src[i] | src[i + 1] << 8, i + 2
        length = min(more(token & 15) + 4, size - len(out))
        chunk = out[-off:] if off else b""  # an offset of 0 is no LZ4: the scan ends (ZeroDivisionError)
        out += (chunk * (length // len(chunk) + 1))[:length]
    return bytes(out[:size])


def _crate(m, base: int) -> str | None:
    version = tuple(m[base + 8:base + 11])
    (toc,) = struct.unpack_from("<q", m, base + 16)
    (count,) = struct.unpack_from("<Q", m, base + toc)
    sections = {}
    for k in range(min(count, 64)):
        name, start, _size = struct.unpack_from("<16sqq", m, base + toc + 8 + 32 * k)
        sections[name.rstrip(b"\0")] = base + start
    (specs,) = struct.unpack_from("<Q", m, sections[b"SPECS"])
    if specs > MAX_SPECS:
        return f"holds {specs:,} specs (prims and properties); the budget is {MAX_SPECS:,}"
    at = sections[b"FIELDS"]
    n_fields, skip = struct.unpack_from("<QQ", m, at)  # then the compressed token indices, then the value reps
    if version < (0, 4, 0) or n_fields > 16 * MAX_SPECS:  # (fields uncompressed before crate 0.4: USD 2018)
        return None if version < (0, 4, 0) else f"holds {n_fields:,} fields; the budget is {16 * MAX_SPECS:,}"
    (size,) = struct.unpack_from("<Q", m, at + 16 + skip)
    data = m[at + 24 + skip:at + 24 + skip + size]
    if data[0]:  # TfFastCompression: 0, one LZ4 block; else chunks, which only a section over 2 GB needs
        return f"holds {n_fields:,} fields in chunks, which no writer makes for under 2 GB: not scanned, so refused"
    reps = _lz4(data[1:], 8 * n_fields)
    fmt = "<Q" if version >= (0, 7, 0) else "<I"
    for (rep,) in struct.iter_unpack("<Q", reps[:len(reps) // 8 * 8]):
        if rep >> 63 and not rep >> 62 & 1:  # an array stored out of line: its element count heads it
            (n,) = struct.unpack_from(fmt, m, base + (rep & (1 << 48) - 1))
            if n > MAX_ARRAY:
                return f"holds an array of {n:,} elements; the budget is {MAX_ARRAY:,}"
    return None


@contextlib.contextmanager
def _opened(identifier: str):
    """``(bytes, offset, size)`` of a file, a usdz's first file or ``a.usdz[b.usdc]``, mapped; else None."""
    from pxr import Ar, Sdf

    path, inner = (Ar.SplitPackageRelativePathOuter(identifier) if Ar.IsPackageRelativePath(identifier)
                   else (identifier, None))
    base, size = 0, None
    if inner is not None or path.lower().endswith(".usdz"):
        zf = Sdf.ZipFile.Open(path)
        names = list(zf.GetFileNames()) if zf else []
        inner = inner if inner is not None else (names[0] if names else None)
        if inner is None or inner not in names:
            yield None  # USD reports what it cannot open
            return
        info = zf.GetFileInfo(inner)
        base, size = info.dataOffset, info.size
    with open(path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as m:
        yield m, base, len(m) - base if size is None else size


def _scan(identifier: str, fn) -> str | None:
    try:
        with _opened(identifier) as found:
            return fn(*found) if found else None
    except (OSError, ValueError, struct.error, IndexError, KeyError, ZeroDivisionError):
        return None  # not a file we can scan (its reader says what is wrong with it)


def _layer(m, base: int, size: int) -> str | None:
    if m[base:base + 8] == b"PXR-USDC":
        return _crate(m, base)
    if size > MAX_TEXT_BYTES:
        return f"is {size / 2**20:,.0f} MiB of text; the budget is {MAX_TEXT_BYTES >> 20} MiB"
    prims = len(_PRIM.findall(m, base, base + size))
    return f"holds {prims:,} prims; the budget is {MAX_SPECS:,}" if prims > MAX_SPECS else None


def _image(m, base: int, size: int) -> str | None:
    head = m[base:base + min(size, 1 << 16)]
    if head.startswith(b"\x89PNG\r\n\x1a\n"):
        w, h = struct.unpack_from(">II", head, 16)
    elif head.startswith(b"\x76\x2f\x31\x01"):  # OpenEXR: attributes (name, type, size, value) up to an empty name
        at, w, h = 8, 0, 0
        while head[at] != 0:
            name, kind, rest = head[at:].split(b"\0", 2)
            (n,) = struct.unpack_from("<i", rest)
            at += len(name) + len(kind) + 6
            if name == b"dataWindow":
                x0, y0, x1, y1 = struct.unpack_from("<iiii", head, at)
                w, h = x1 - x0 + 1, y1 - y0 + 1
            at += n
    else:
        return None
    if w * h > MAX_TEXELS:
        return f"is an image of {w:,} x {h:,} texels; the budget is {MAX_TEXELS:,} (4096 x 4096)"
    return None


def over_budget(identifier: str) -> str | None:
    """Why the layer ``identifier`` (file, usdz or ``a.usdz[b.usdc]``) is over a budget, from its bytes, or None."""
    return _scan(identifier, _layer)


def image_over_budget(identifier: str) -> str | None:
    """Why the PNG or EXR ``identifier`` is over :data:`MAX_TEXELS`, from its header alone, or None."""
    return _scan(identifier, _image)


def face_over_budget(counts) -> str | None:
    """Why a ``faceVertexCounts`` value is over :data:`MAX_FACE`, or None."""
    import numpy as np

    big = int(np.max(np.asarray(counts))) if counts is not None and len(counts) else 0
    return f"has a face of {big:,} vertices; the budget is {MAX_FACE:,}" if big > MAX_FACE else None
