"""``DIR/pigeon.usdz``: the asset as one self-contained package (USDZ: an uncompressed, 64-byte aligned zip).

Made with ``UsdUtils.CreateNewUsdzPackage``, which collects the root layer and every dependency it reaches
(the payload layer, the textures, and the LUT named by ``rockdove:lut:file``, an asset-valued attribute) and
rewrites their paths to package-relative ones.

Reproducibility: usd-core's zip writer stores each source file's modification time in the archive. The
package is therefore made from a scratch copy of the asset whose files all carry one fixed time,
``SOURCE_DATE_EPOCH`` when set (the reproducible-builds convention) else 1980-01-01 (the zip epoch), so the
same asset gives a byte-identical package (tested) and the files in ``out_dir`` are left untouched.
"""

from __future__ import annotations

import os

USDZ_NAME = "pigeon.usdz"
#: 1980-01-01T00:00:00Z, the earliest time a zip (DOS) timestamp can hold.
ZIP_EPOCH = 315532800


def _fixed_time() -> int:
    value = os.environ.get("SOURCE_DATE_EPOCH")
    if value is None:
        return ZIP_EPOCH
    try:
        return max(int(value), ZIP_EPOCH)
    except ValueError:
        raise ValueError(f"SOURCE_DATE_EPOCH must be an integer (seconds), got {value!r}") from None


def write_usdz(out_dir: str, root_layer: str = "pigeon.usda", *, in_place: bool = False) -> str:
    """Package ``out_dir/root_layer`` and its dependencies into ``out_dir/pigeon.usdz``.

    ``in_place=True`` packages ``out_dir``'s own files, setting their modification times to the fixed time,
    instead of a scratch copy of them: for a caller whose ``out_dir`` is already its own scratch copy (the build's
    usdz stage), the same bytes without copying the asset a second time.

    Returns
    -------
    str
        Absolute path of the package.

    Raises
    ------
    FileNotFoundError
        The root layer does not exist.
    RuntimeError
        USD could not write the package.
    """
    import shutil
    import tempfile

    from pxr import Sdf, UsdUtils

    from .schema import register

    register()
    out_dir = os.path.abspath(out_dir)
    root = os.path.join(out_dir, root_layer)
    if not os.path.isfile(root):
        raise FileNotFoundError(f"out_dir: no root layer {root!r} to package")
    target = os.path.join(out_dir, USDZ_NAME)
    stamp = _fixed_time()
    with tempfile.TemporaryDirectory(prefix=".usdz-", dir=out_dir) as scratch:
        src = out_dir
        if not in_place:
            src = os.path.join(scratch, "asset")
            shutil.copytree(out_dir, src, ignore=lambda d, names: [n for n in names if n.endswith(".usdz")
                                                                   or n.startswith(".usdz-")])
        for folder, dirs, files in os.walk(src):
            dirs[:] = [d for d in dirs if not d.startswith(".usdz-")]
            for name in files:
                if not name.endswith(".usdz"):
                    os.utime(os.path.join(folder, name), (stamp, stamp))
        package = os.path.join(scratch, USDZ_NAME)
        if not UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(os.path.join(src, root_layer)), package):
            raise RuntimeError(f"UsdUtils.CreateNewUsdzPackage failed for {root!r}")
        os.replace(package, target)
    return target


def usdz_contents(path: str) -> list[str]:
    """File names stored in a usdz package, in archive order."""
    from pxr import Sdf

    zf = Sdf.ZipFile.Open(path)
    if zf is None:
        raise ValueError(f"path={path!r} is not a readable usdz package")
    return list(zf.GetFileNames())
