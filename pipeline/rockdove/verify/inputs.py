"""What a verification reads: the asset as a scene, the views it renders, and the digest of the scene content
they render (:func:`scene_digest`), which keys each view's cache entry (:mod:`rockdove.verify.verification`)."""

from __future__ import annotations

import numpy as np

from ..digest import Digest
from ..errors import UsageError

#: The light-view angle (deg) of the extra sweep view: 90 deg is the paper's green/purple flip.
BOUNDARY_SWEEP_ANGLE_DEG = 90.0
#: The report's note for an asset without a LUT (physical-only shading).
PHYSICAL_ONLY_NOTE = (
    "physical-only asset (no LUT): its MaterialX shading hands the film to a renderer's own thin-film BSDF, which "
    "no renderer here implements; the GL renderer draws the paper's LUT method, so verification baked a "
    "verification-only LUT ({shape}, {lo:g}-{hi:g} nm, not part of the asset) in memory from the film the asset "
    "records (RockDoveThinFilmAPI) and checked it against the exact spectral reference: geometry, textures, "
    "thickness primvar and film are verified; the physical MaterialX network itself is only validated")


def verification_scene(asset):
    """Read an asset back for verification: ``(root layer, RenderScene, LUT or None, notes)``; for a LUT-less
    (physical-only) asset a LUT baked in memory from the film it records, and :data:`PHYSICAL_ONLY_NOTE`."""
    from ..render.scene import load_scene

    scene = load_scene(asset)
    if scene.film is None or scene.film.lut_file is not None:
        return scene.root_layer, scene, None, []
    lut = scene.load_lut()
    lo, hi = lut.thickness_range_nm
    note = PHYSICAL_ONLY_NOTE.format(shape=f"{lut.n_thickness} x {lut.n_angle}", lo=lo, hi=hi)
    return scene.root_layer, scene, lut, [note]


def verification_views(scene, width: int, height: int, n_views: int) -> list:
    """The default views (``n_views`` of them), the light sweep at :data:`BOUNDARY_SWEEP_ANGLE_DEG` (same still
    camera), and the hero 3/4 view at ``HERO_SCALE`` times the size (:func:`rockdove.render.views.hero_view`)."""
    from ..render.views import HERO_SCALE, default_views, hero_view, light_sweep_views

    views = default_views(scene, width, height, n=n_views)
    sweep = [v for v in views if v.name.startswith("sweep_")]
    if sweep:
        neck = np.asarray(scene.neck_centre_m, np.float64)
        eye = sweep[0].camera_to_world[:3, 3]
        dist = float(np.linalg.norm(eye - neck))
        extra = light_sweep_views(neck, 1, width, height, angles_deg=[BOUNDARY_SWEEP_ANGLE_DEG], distance_m=dist,
                                  yfov_deg=float(np.degrees(sweep[0].yfov_rad)), camera_direction=(eye - neck) / dist)
        if extra[0].name not in {v.name for v in views}:
            views.append(extra[0])
    views.append(hero_view(scene.bounds_m, HERO_SCALE * width, HERO_SCALE * height))
    return views


def sizes(width=None, height=None, n_views=None) -> tuple[int, int, int]:
    """A verification's render size (pixels, checked against the schema's limits) and number of views, the schema's
    ``[verify]`` defaults (the one place they are set) where None."""
    from ..config import defaults, limits

    d = defaults()["verify"]
    out = tuple(d[k] if v is None else v for k, v in (("width", width), ("height", height), ("views", n_views)))
    for key, v in zip(("width", "height"), out):
        lo, hi = limits(f"verify.{key}")
        if isinstance(v, bool) or int(v) != v or not lo <= int(v) <= hi:
            raise UsageError(f"{key} must be an integer from {lo} to {hi} pixels, got {v!r}")
    return out


def select_views(all_views: list, names) -> list:
    if names is None:
        return list(all_views)
    known = {v.name: v for v in all_views}
    names = list(names)
    unknown = [n for n in names if n not in known]
    if unknown or not names:
        raise UsageError(f"views={names!r}: unknown or none; allowed names: {sorted(known)}")
    return [known[n] for n in dict.fromkeys(names)]


def scene_digest(scene) -> str:
    """sha256 of what a verification view reads from a scene (arrays, material values, textures, film, LUT,
    variants), not file paths: an asset moved or rebuilt with the same content has the same digest."""
    d = Digest()
    for p in scene.parts:
        d.add("part", {"name": p.name, "kind": p.material_kind, "srgb": bool(p.base_colour_srgb),
                       "base_colour": np.asarray(p.base_colour, np.float64).tolist(),
                       "opacity_threshold": float(p.opacity_threshold), "double_sided": bool(p.double_sided)})
        for f in ("positions_m", "normals", "triangles", "st", "thickness_nm", "neck_s"):
            if getattr(p, f) is not None:
                d.add(f"{p.name}.{f}", getattr(p, f))
        d.file(f"{p.name}.base", p.base_colour_texture).file(f"{p.name}.mask", p.mask_texture)
    if scene.film is not None:
        d.add("film", {k: v for k, v in scene.film.to_dict().items() if k != "lut_file"})
        d.file("lut", scene.film.lut_file)
    return d.add("variants", dict(scene.variants)).hexdigest()
