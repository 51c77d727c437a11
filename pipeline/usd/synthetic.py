"""Small synthetic inputs for the USD stage: a stand-in bird, textures and LUT (for tests and examples).

They follow the data contracts of docs/design.md (MeshPart/Bird, uint8 textures, ThinFilmLUT) but are not the
rock dove: an icosphere body, a cone beak and ``card_count`` flat quads on a ring around the "neck", with a
thickness primvar rising linearly from ``thickness_range_nm[0]`` at the lowest card to ``[1]`` at the highest.
Fast (milliseconds), deterministic for the same arguments.
"""

from __future__ import annotations

import numpy as np


def synthetic_bird(card_count: int = 12, seed: int = 0, thickness_range_nm=(480.0, 700.0)):
    """A stand-in :class:`pipeline.geometry.Bird` with Body, Beak and NeckFeathers (``card_count`` quads)."""
    import trimesh

    from pipeline.geometry import Bird, MeshPart, Primvar

    if not (isinstance(card_count, int) and card_count >= 1):
        raise ValueError(f"card_count must be an int >= 1, got {card_count!r}")
    lo, hi = (float(v) for v in thickness_range_nm)
    rng = np.random.default_rng(seed)
    body = trimesh.creation.icosphere(subdivisions=2, radius=0.12)
    body.apply_translation([0.0, 0.15, 0.0])
    v = np.asarray(body.vertices, np.float32)
    n = np.asarray(body.vertex_normals, np.float32)
    st = np.stack([0.5 + np.arctan2(n[:, 0], n[:, 2]) / (2 * np.pi), 0.5 + 0.5 * n[:, 1]], 1).astype(np.float32)
    faces = np.asarray(body.faces, np.int32)
    body_part = MeshPart("Body", v, np.full(len(faces), 3, np.int32), faces.ravel(), n, st, "body",
                         (0.35, 0.37, 0.42))
    beak = trimesh.creation.cone(radius=0.015, height=0.04, sections=8)
    beak.apply_translation([0.0, 0.2, 0.11])
    bf = np.asarray(beak.faces, np.int32)
    bv = np.asarray(beak.vertices, np.float32)
    beak_part = MeshPart("Beak", bv, np.full(len(bf), 3, np.int32), bf.ravel(),
                         np.asarray(beak.vertex_normals, np.float32), np.zeros((len(bv), 2), np.float32), "beak",
                         (0.05, 0.04, 0.04))
    # cards: quads tangent to a ring at the neck, each 2 cm wide, 3 cm high
    angle = np.sort(rng.uniform(0, 2 * np.pi, card_count))
    height = 0.22 + 0.06 * np.arange(card_count) / max(card_count - 1, 1)
    centre = np.stack([0.05 * np.sin(angle), height, 0.05 * np.cos(angle)], 1)
    normal = np.stack([np.sin(angle), np.zeros(card_count), np.cos(angle)], 1)
    tangent = np.stack([np.cos(angle), np.zeros(card_count), -np.sin(angle)], 1)
    up = np.array([0.0, 1.0, 0.0])
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], np.float64)  # CCW seen along +normal
    pts = (centre[:, None] + 0.01 * corners[None, :, :1] * tangent[:, None]
           + 0.015 * corners[None, :, 1:] * up).reshape(-1, 3).astype(np.float32)
    nrm = np.repeat(normal, 4, axis=0).astype(np.float32)
    card_st = np.tile(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32), (card_count, 1))
    frac = np.repeat((height - height.min()) / max(np.ptp(height), 1e-9), 4)
    thickness = (lo + (hi - lo) * frac).astype(np.float32)
    feathers = MeshPart(
        "NeckFeathers", pts, np.full(card_count, 4, np.int32), np.arange(4 * card_count, dtype=np.int32), nrm,
        card_st, "feather", (0.2, 0.3, 0.25),
        {"thickness": Primvar(thickness, "vertex", "film thickness, nm"),
         "neckS": Primvar(frac.astype(np.float32), "vertex", "position along the neck band, 0 (base) to 1")})
    return Bird((body_part, beak_part, feathers))


def synthetic_textures(size: int = 16):
    """``(feather_textures, body_texture)``: {"base": (size, size, 4), "mask": (size, size)} and (size, size, 3), uint8."""
    y, x = np.mgrid[0:size, 0:size] / max(size - 1, 1)
    alpha = (np.abs(x - 0.5) < 0.5 - 0.5 * y * 0.6).astype(np.uint8) * 255  # tapering silhouette
    base = np.stack([x * 60 + 40, x * 40 + 50, y * 50 + 60, alpha], -1).astype(np.uint8)
    mask = (y < 0.5).astype(np.uint8) * 255  # image row 0 is the top: the tip (t near 1) is structural
    body = np.stack([x * 80 + 60, y * 80 + 70, np.full_like(x, 110)], -1).astype(np.uint8)
    return {"base": base, "mask": mask}, body


def synthetic_lut(n_thickness: int = 8, n_angle: int = 16, thickness_range_nm=(450.0, 750.0),
                  angle_warp_gamma: float = 2.0):
    """A smooth stand-in :class:`pipeline.lut.ThinFilmLUT` (cosines of a fake phase, not physics)."""
    from pipeline.lut import ThinFilmLUT

    lo, hi = thickness_range_nm
    d = np.linspace(lo, hi, n_thickness)[:, None]
    c = np.linspace(0, 1, n_angle)[None, :] ** angle_warp_gamma
    phase = 4 * np.pi * 1.5 * d * np.sqrt(1 - (1 - c**2) / 2.25)
    rgb = np.stack([0.5 + 0.4 * np.cos(phase / w) for w in (610.0, 540.0, 465.0)], -1).astype(np.float32)
    return ThinFilmLUT(rgb, (lo, hi), angle_warp_gamma=angle_warp_gamma,
                       metadata={"method": "synthetic (tests only)", "illuminant": "D65"})
