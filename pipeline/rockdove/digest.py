"""The one digest helper: the sha256 of what something reads (a scene's arrays and textures, a folder's files, a
module's source), part by part. Each part is its label, NUL, its bytes, NUL, so parts cannot run together; an
array's part holds its dtype and shape too. Cache keys are built from these digests (:mod:`rockdove.graph`)."""

from __future__ import annotations

import hashlib
import json
import sys


class Digest:
    """``Digest().add("points", array).file("texture", path).hexdigest()``."""

    def __init__(self):
        self._h = hashlib.sha256()

    def add(self, label: str, value=b"") -> Digest:
        """Add ``value``: bytes as they are, text as UTF-8, a numpy array by dtype, shape and bytes, anything
        else as sorted-key JSON (``str`` for what JSON cannot hold)."""
        np = sys.modules.get("numpy")  # no array exists before numpy is imported: a no-op rebuild never imports it
        if np is not None and isinstance(value, np.ndarray):
            a = np.ascontiguousarray(value)
            label, value = f"{label}:{a.dtype.str}:{a.shape}", a.tobytes()
        elif isinstance(value, str):
            value = value.encode()
        elif not isinstance(value, bytes):
            value = json.dumps(value, sort_keys=True, default=str).encode()
        self._h.update(label.encode() + b"\0" + value + b"\0")
        return self

    def file(self, label: str, path) -> Digest:
        """Add the bytes of the file at ``path``, streamed (nothing but the label when ``path`` is empty)."""
        self._h.update(label.encode() + b"\0")
        if path:
            with open(path, "rb") as f:
                while chunk := f.read(1 << 20):
                    self._h.update(chunk)
        self._h.update(b"\0")
        return self

    def hexdigest(self) -> str:
        return self._h.hexdigest()


def file_sha256(path) -> str:
    """The plain sha256 of one file's bytes (what a report records about the layer it verified)."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()
