"""Check 5 of :mod:`rockdove.usd.validate`: the thin film against its LUT (domain, header, constants, provenance),
and a film recorded without a LUT (a physical-only asset)."""

from __future__ import annotations

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

from .issues import Issue
from .material import lut_info, lut_transform
from .schema import has_thin_film, read_thin_film


def check_thin_film(stage, decoded: dict) -> tuple[list, int]:
    """Check 5: (issues, number of films checked)."""
    issues, n = [], 0
    for prim in Usd.PrimRange(stage.GetPseudoRoot()):
        if not has_thin_film(prim):
            continue
        n += 1
        film = read_thin_film(prim)
        if not film["lut_file"] and not any(prim.GetAttribute(f"rockdove:lut:{a}").HasAuthoredValue() for a in
                                            ("colorSpace", "angleWarpGamma", "thicknessRangeNm")):
            issues += _check_lutless_film(prim, film)
            continue
        rng = film["thickness_range_nm"]
        where = f"{prim.GetPath()}.rockdove:lut:thicknessRangeNm"
        if rng is None:
            issues.append(Issue("thinFilm", where, "not authored; expected the LUT's (lo, hi) in nm"))
            continue
        lo, hi = rng
        lut = decoded.get(film["lut_file_resolved"])
        if lut is not None and hasattr(lut, "thickness_range_nm"):
            elo, ehi = lut.thickness_range_nm
            if not (np.isclose(lo, elo, rtol=0, atol=1e-3) and np.isclose(hi, ehi, rtol=0, atol=1e-3)):
                issues.append(Issue("thinFilm", where, f"({lo}, {hi}) nm differs from the LUT file's header "
                                    f"rockdove:thicknessRangeNm ({elo}, {ehi})"))
            if not np.isclose(film["angle_warp_gamma"], lut.angle_warp_gamma, rtol=1e-6):
                issues.append(Issue("thinFilm", f"{prim.GetPath()}.rockdove:lut:angleWarpGamma",
                                    f"{film['angle_warp_gamma']} differs from the LUT file's {lut.angle_warp_gamma}"))
            issues += _check_lut_constants(prim, lut)
            issues += _check_film_provenance(prim, film, lut)
        pv, d = _thickness(prim, film, issues)
        tol = 1e-3  # nm: float32 rounding of authored values
        if d is not None and (d.min() < lo - tol or d.max() > hi + tol):
            issues.append(Issue("thinFilm", str(pv.GetAttr().GetPath()),
                                f"thickness spans [{d.min():.6g}, {d.max():.6g}] nm, outside the LUT domain "
                                f"[{lo:.6g}, {hi:.6g}] nm (rockdove:lut:thicknessRangeNm)"))
    return issues, n


def _thickness(prim, film: dict, issues: list):
    """The film's thickness primvar and its values in nm, or (pv, None) with an issue when missing or empty."""
    pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar(film["thickness_primvar"] or "")
    values = pv.ComputeFlattened() if pv else None
    if values is None or len(values) == 0:
        issues.append(Issue("thinFilm", f"{prim.GetPath()}.primvars:{film['thickness_primvar']}",
                            "thickness primvar missing or empty"))
        return pv, None
    return pv, np.asarray(values, np.float64)


#: Names of the shaders of the baked LUT network (thinfilm.mtlx) that read the LUT.
LUT_NETWORK_SHADERS = ("LutTexture", "LutTransform", "LutAngleWarpExponent")


def _check_lutless_film(prim, film: dict) -> list:
    """A film recorded without a LUT (physical-only asset): complete film, sane thickness, no LUT network."""
    issues = []
    for key, attr in (("cauchy_a", "film:cauchyA"), ("cauchy_b_nm2", "film:cauchyB_nm2"), ("k", "film:k"),
                      ("incident_index", "film:incidentIndex"), ("substrate_index", "film:substrateIndex")):
        v = film.get(key)
        if not isinstance(v, float) or not np.isfinite(v):
            issues.append(Issue("thinFilm", f"{prim.GetPath()}.rockdove:{attr}", f"{v!r}; expected a finite number"))
    if film.get("thickness_units") != "nm":
        issues.append(Issue("thinFilm", f"{prim.GetPath()}.rockdove:film:thicknessUnits",
                            f"{film.get('thickness_units')!r}; expected 'nm'"))
    pv, d = _thickness(prim, film, issues)
    if d is not None and (not np.all(np.isfinite(d)) or d.min() <= 0):
        issues.append(Issue("thinFilm", str(pv.GetAttr().GetPath()),
                            f"thickness spans [{np.nanmin(d):.6g}, {np.nanmax(d):.6g}] nm; expected finite "
                            "values > 0 nm"))
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if present := [n for n in LUT_NETWORK_SHADERS if material and material.GetPrim().GetChild(n)]:
        issues.append(Issue("thinFilm", str(material.GetPath()),
                            f"holds the baked LUT network ({', '.join(present)}) but {prim.GetPath()} records no "
                            "LUT (no rockdove:lut:file): a physical-only asset carries only the physical network"))
    return issues


#: read_thin_film key -> (schema attribute, LUT EXR metadata key written by rockdove.lut.bake)
_PROVENANCE = {
    "model": ("rockdove:film:model", "film:name"),
    "cauchy_a": ("rockdove:film:cauchyA", "film:cauchyA"),
    "cauchy_b_nm2": ("rockdove:film:cauchyB_nm2", "film:cauchyB_nm2"),
    "k": ("rockdove:film:k", "film:k"),
    "incident_index": ("rockdove:film:incidentIndex", "film:incidentIndex"),
    "substrate_index": ("rockdove:film:substrateIndex", "film:substrateIndex"),
    "illuminant": ("rockdove:lut:illuminant", "illuminant"),
    "observer": ("rockdove:lut:observer", "observer"),
    "lut_colour_space": ("rockdove:lut:colorSpace", None),
}


def _check_film_provenance(prim, film: dict, lut) -> list:
    """The schema's film must be the one the LUT was baked from (the EXR header's provenance, when recorded)."""
    issues = []
    for key, (attr, meta_key) in _PROVENANCE.items():
        if meta_key is None:
            recorded = lut.colour_space
        elif meta_key in lut.metadata:
            recorded = lut.metadata[meta_key]
        else:
            continue
        got = film.get(key)
        if isinstance(got, float):
            try:
                same = abs(got - float(recorded)) <= 1e-6 * max(1.0, abs(float(recorded)))
            except ValueError:
                same = False
        else:
            same = str(got) == str(recorded)
        if not same:
            issues.append(Issue("thinFilm", f"{prim.GetPath()}.{attr}",
                                f"{got!r} differs from the LUT file's {meta_key or 'colour space'} = {recorded!r}: "
                                "the schema must record the film the LUT was baked from"))
    return issues


def _check_lut_constants(prim, lut) -> list:
    """The MaterialX network's LUT constants (texel counts, warp, range) must describe the LUT file it reads."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if not material:
        return [Issue("thinFilm", str(prim.GetPath()), "feather mesh has no bound material")]
    lo, hi = lut.thickness_range_nm
    expected = {"LutTransform": lut_transform(lut_info(lut)),
                "LutAngleWarpExponent": 1.0 / lut.angle_warp_gamma - 1.0}
    issues = []
    for name, want in expected.items():
        if not (shader := UsdShade.Shader(material.GetPrim().GetChild(name))):
            continue  # a material without the LUT network (e.g. hand-made) has nothing to disagree with
        got = shader.GetInput("value").Get() if shader.GetInput("value") else None
        flat = None if got is None else np.ravel(np.asarray(got, np.float64))
        if flat is None or flat.size != np.size(want) or not np.allclose(flat, want, rtol=1e-6, atol=1e-9):
            issues.append(Issue("thinFilm", f"{shader.GetPath()}.inputs:value",
                                f"{got} does not describe the LUT file it reads: expected {want} "
                                f"({lut.n_thickness} x {lut.n_angle} texels, gamma {lut.angle_warp_gamma}, "
                                f"range ({lo}, {hi}) nm)"))
    return issues
