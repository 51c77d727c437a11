"""Reference files the tests check against, taken from PyPI packages with ``pip download --no-deps`` (not copied
into the repository): OpenUSD's ARKit compliance checker of v23.11 and v24.08 (``pxr/UsdUtils/complianceChecker.py``
of the usd-core wheels; usd-core 26.11 no longer ships it, and 23.11 has no cp311 wheel: the module is pure Python,
so the cp310 wheel's is the same file) and the JUnit schema CI tools read (the Jenkins xunit plugin's
``junit-10.xsd``, which pytest's sdist carries for its own ``--junitxml`` tests).

``make test`` runs ``python tests/fetched.py`` once (a stamp); a test that finds a file missing fetches it the same
way. Files go to ``.venv/fetched/`` (``$ROCKDOVE_FETCHED`` overrides).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
import tempfile
import types
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: name -> (pip requirement, extra pip arguments, member of the downloaded archive)
FILES = {
    "complianceChecker-23.11.py": ("usd-core==23.11", ["--only-binary", ":all:", "--python-version", "3.10",
                                                       "--platform", "manylinux2014_x86_64"],
                                   "pxr/UsdUtils/complianceChecker.py"),
    "complianceChecker-24.08.py": ("usd-core==24.8", ["--only-binary", ":all:", "--python-version", "3.11",
                                                      "--platform", "manylinux2014_x86_64"],
                                   "pxr/UsdUtils/complianceChecker.py"),
    "junit-10.xsd": ("pytest==8.3.5", ["--no-binary", ":all:"],
                     "pytest-8.3.5/testing/example_scripts/junit-10.xsd"),
}
#: usd-core 26.11's names for what the v23.11/v24.08 checkers call (old text -> new text, each must occur).
RENAMES = {
    "Usd.ZipFile": "_pxr.Sdf.ZipFile",  # Usd.ZipFile moved to Sdf.ZipFile (25.05)
    "shadeNode.GetInputNames()": "shadeNode.GetShaderInputNames()",  # Sdr: NdrNode -> SdrShaderNode (25.05)
    "shadeNode.GetInput(inputName)": "shadeNode.GetShaderInput(inputName)",
    "sdfType, sdfHint = prop.GetTypeAsSdfType()": "sdfType = prop.GetTypeAsSdfType().GetSdfType()",  # now a class
}


def folder() -> Path:
    return Path(os.environ.get("ROCKDOVE_FETCHED", ROOT / ".venv" / "fetched"))


def fetch(name: str) -> Path:
    """The path of ``name`` (a key of :data:`FILES`), downloaded and extracted when it is not there yet."""
    out = folder() / name
    if out.is_file():
        return out
    requirement, extra, member = FILES[name]
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "-d", tmp, *extra,
                        requirement], check=True, stdout=subprocess.DEVNULL)
        (archive,) = Path(tmp).iterdir()
        if archive.suffix == ".whl":
            data = zipfile.ZipFile(archive).read(member)
        else:
            data = tarfile.open(archive).extractfile(member).read()
    tmp_out = out.with_suffix(".tmp")
    tmp_out.write_bytes(data)
    tmp_out.replace(out)
    return out


def compliance_checker(version: str) -> types.ModuleType:
    """OpenUSD's ``complianceChecker`` module of ``version`` ("23.11" or "24.08"), with :data:`RENAMES` applied
    to its source so that it runs on the usd-core installed here."""
    import pxr

    source = fetch(f"complianceChecker-{version}.py").read_text()
    for old, new in RENAMES.items():
        if old in source:
            source = source.replace(old, new)
        elif not (version == "23.11" and old.startswith(("shadeNode", "sdfType"))):  # v23.11 has no type check
            raise AssertionError(f"complianceChecker {version} has no {old!r}: the renames are out of date")
    module = types.ModuleType(f"complianceChecker_{version.replace('.', '_')}")
    module._pxr = pxr
    exec(compile(source, f"complianceChecker-{version}.py", "exec"), module.__dict__)
    return module


def arkit_failures(version: str, path) -> list[str]:
    """The failed checks, errors and warnings of the ARKit rules of ``version`` on the usdz ``path``."""
    checker = compliance_checker(version).ComplianceChecker(arkit=True, skipARKitRootLayerCheck=False,
                                                            rootPackageOnly=False, skipVariants=False)
    checker.CheckCompliance(os.fspath(path))
    return [*checker.GetFailedChecks(), *checker.GetErrors(), *checker.GetWarnings()]


if __name__ == "__main__":  # make test: fetch everything once
    for key in FILES:
        print(fetch(key))
    if len(sys.argv) > 1:  # a stamp file to touch
        Path(sys.argv[1]).touch()
