"""Write the asset's textures into ``DIR/textures/`` deterministically (docs/design.md, "Textures").

``feather_preview.png`` is what UsdPreviewSurface viewers show (Blender's importer, usdview without MaterialX,
Quick Look), which cannot look the LUT up per fragment: an atlas of :data:`PREVIEW_TILES` copies of the feather,
each mixed in linear light with the colour of one thickness; each card reads its own tile through ``previewST``."""

from __future__ import annotations

import os

import numpy as np

from ..errors import UsageError
from .material import TEXTURE_FILES

#: cos theta of the structural colours of feather_preview.png: 0.86 (31 degrees), the median |N.V| over the
#: feather-tip pixels of the default verification views (4 turntable + the light sweep, 128 px, measured on the
#: default build: median 0.865, quartiles 0.65 and 0.96): the incidence a viewer most often sees the tips at.
PREVIEW_COS_THETA = 0.86
#: Thickness tiles of the preview atlas (cards round to the nearest; 32 over the default ~208 nm range is a
#: 6.7 nm step, a hue step of ~13 degrees at the film's ~175 nm per colour order).
PREVIEW_TILES = 32
#: Columns of the atlas; texels per tile side (the feather preview is resized to it).
PREVIEW_COLUMNS = 8
PREVIEW_TILE_TEXELS = 128


def preview_range_nm(thickness_range_nm) -> tuple[float, float]:
    """``(lo, hi)`` nm rounded outward to whole nm, so that callers holding the mesh's exact range and callers
    holding the build's rounded one (the LUT axis) pick the same tiles."""
    lo, hi = (float(v) for v in thickness_range_nm)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo <= hi):
        raise UsageError(f"thickness_range_nm must be finite (lo, hi) with 0 <= lo <= hi nm, "
                         f"got {thickness_range_nm!r}")
    return float(np.floor(lo)), float(np.ceil(hi))


def preview_tile_thickness_nm(thickness_range_nm) -> np.ndarray:
    """(K,) float64 thickness of each atlas tile, nm (K = 1 when the range is one value, else PREVIEW_TILES)."""
    lo, hi = preview_range_nm(thickness_range_nm)
    return np.array([lo]) if hi == lo else np.linspace(lo, hi, PREVIEW_TILES)


def preview_atlas_shape(n_tiles: int) -> tuple[int, int]:
    """(columns, rows) of an atlas of ``n_tiles`` tiles."""
    cols = min(int(n_tiles), PREVIEW_COLUMNS)
    return cols, -(-int(n_tiles) // cols)


def preview_st(st, thickness_nm, thickness_range_nm) -> np.ndarray:
    """(V, 2) float32 ``st`` mapped onto the texel centres (no bleeding between tiles) of its thickness's tile."""
    st = np.asarray(st, np.float64)
    d = np.asarray(thickness_nm, np.float64).reshape(-1)
    tiles = preview_tile_thickness_nm(thickness_range_nm)
    k = np.zeros(d.size, np.int64) if tiles.size == 1 else np.clip(
        np.rint((d - tiles[0]) / (tiles[-1] - tiles[0]) * (tiles.size - 1)), 0, tiles.size - 1).astype(np.int64)
    cols, rows = preview_atlas_shape(tiles.size)
    t = PREVIEW_TILE_TEXELS
    inner = 0.5 + np.clip(st, 0.0, 1.0) * (t - 1)  # texel coordinate inside the tile, centre to centre
    s = ((k % cols) * t + inner[:, 0]) / (cols * t)
    v = ((k // cols) * t + inner[:, 1]) / (rows * t)
    return np.stack([s, v], axis=1).astype(np.float32)


def feather_preview_atlas(base_rgba: np.ndarray, mask: np.ndarray, structural_rgb) -> np.ndarray:
    """The (rows * T, columns * T, 4) uint8 atlas: a tile per linear colour (K, 3), bottom row first."""
    from PIL import Image

    colours = np.asarray(structural_rgb, np.float64).reshape(-1, 3)
    cols, rows = preview_atlas_shape(len(colours))
    t = PREVIEW_TILE_TEXELS
    atlas = np.zeros((rows * t, cols * t, 4), np.uint8)
    base_rgba = _check_uint8("base_rgba", base_rgba, (4,))
    mask = _check_uint8("mask", mask, (1,))
    if mask.shape[:2] != base_rgba.shape[:2] or not np.all(np.isfinite(colours)):
        raise UsageError(f"mask {mask.shape[:2]} must match base_rgba {base_rgba.shape[:2]} and the colours be finite")
    for k, tile in enumerate(_mixed_tiles(base_rgba, mask, colours)):
        if tile.shape[:2] != (t, t):
            tile = np.asarray(Image.fromarray(tile, "RGBA").resize((t, t), Image.BOX))
        top = (rows - 1 - k // cols) * t  # image row 0 is the top (t = 1)
        atlas[top:top + t, (k % cols) * t:(k % cols + 1) * t] = tile
    return atlas


def _check_uint8(name: str, a, channels: tuple[int, ...]) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype != np.uint8:
        raise UsageError(f"{name} must be uint8, got dtype {a.dtype}")
    c = 1 if a.ndim == 2 else (a.shape[2] if a.ndim == 3 else -1)
    if a.ndim not in (2, 3) or c not in channels or min(a.shape[:2]) < 1:
        raise UsageError(f"{name} must have shape (H, W) or (H, W, C) with C in {channels}, got {a.shape}")
    return np.ascontiguousarray(a)


def write_png(path: str, pixels: np.ndarray) -> str:
    """Write a uint8 (H, W), (H, W, 3) or (H, W, 4) image, row 0 at the top, with fixed encoder options."""
    from ..png import TEXTURE_LEVEL, save_png

    return save_png(pixels, path, level=TEXTURE_LEVEL)


def _mixed_tiles(base_rgba: np.ndarray, mask: np.ndarray, colours: np.ndarray):
    """Yield ``mix(base, clip(colour, 0, 1), mask)`` in linear light, sRGB-encoded, one (H, W, 4) uint8 tile per
    colour. Each output channel depends only on its base value and the mask (~900 distinct pairs against 65k
    texels): each pair is mixed once per colour (the same bytes as texel by texel), and a tile is one gather."""
    from rockdove.srgb import srgb_decode, srgb_encode

    h, w = mask.shape[:2]
    b = base_rgba.astype(np.int64)
    key = (((b[..., 0] * 256 + b[..., 1]) * 256 + b[..., 2]) * 256 + mask.reshape(h, w)) * 256 + b[..., 3]
    texels, inverse = np.unique(key.reshape(-1), return_inverse=True)
    alpha, m8 = texels % 256, (texels // 256) % 256
    rgb8 = np.stack([(texels // 256 ** (4 - ch)) % 256 for ch in range(3)], axis=1)  # (U, 3) base R, G, B
    channel_keys = np.arange(3) * 65536 + rgb8 * 256 + m8[:, None]
    uniq, channel_index = np.unique(channel_keys.reshape(-1), return_inverse=True)
    ch, b8, m8 = uniq // 65536, (uniq // 256) % 256, uniq % 256
    m = m8 / 255.0
    base_part = srgb_decode(b8 / 255.0) * (1.0 - m)
    clipped = np.clip(np.asarray(colours, np.float64).reshape(-1, 3), 0.0, 1.0)
    encoded = np.round(srgb_encode(np.clip(base_part + clipped[:, ch] * m, 0.0, 1.0)) * 255.0).astype(np.uint8)
    rgba = np.empty((texels.size, 4), np.uint8)
    rgba[:, 3] = alpha
    for row in encoded:  # (K, distinct channel values)
        rgba[:, :3] = row[channel_index].reshape(-1, 3)
        yield rgba.view(np.uint32).reshape(-1)[inverse.reshape(-1)].view(np.uint8).reshape(h, w, 4)


def _texture_paths(out_dir: str) -> dict[str, str]:
    tex_dir = os.path.join(os.path.abspath(out_dir), "textures")
    os.makedirs(tex_dir, exist_ok=True)
    return {role: os.path.join(tex_dir, name) for role, name in TEXTURE_FILES.items()}


def _feather_images(feather_textures: dict) -> tuple[np.ndarray, np.ndarray]:
    return (_check_uint8("feather_textures['base']", feather_textures["base"], (4,)),
            _check_uint8("feather_textures['mask']", feather_textures["mask"], (1,)))


def write_base_textures(out_dir: str, feather_textures: dict, body_texture: np.ndarray) -> dict[str, str]:
    """Write the textures that do not depend on the film (a film change leaves their bytes): role -> path."""
    base, mask = _feather_images(feather_textures)
    body = _check_uint8("body_texture", body_texture, (3,))
    paths = _texture_paths(out_dir)
    plumage = [(k, _check_uint8(k, feather_textures[k], (4,))) for k in ("plumage_base", "plumage_normal")
               if k in feather_textures]
    written = {role: write_png(paths[role], img)
               for role, img in [("feather_base", base), ("feather_mask", mask), ("body_base", body)] + plumage}
    return dict(sorted(written.items()))


def write_film_textures(out_dir: str, lut, feather_textures: dict, *, thickness_range_nm: tuple[float, float],
                        preview_cos_theta: float = PREVIEW_COS_THETA, film=None) -> dict[str, str]:
    """Write the LUT (``None``: ``film``'s exact colours) and the atlas over the mesh's range, as its previewST."""
    base, mask = _feather_images(feather_textures)
    tiles = preview_tile_thickness_nm(thickness_range_nm)
    if lut is not None:
        colours = lut.sample(np.full(tiles.size, preview_cos_theta), tiles)
    elif film is None:
        raise UsageError("lut=None needs the film for the preview colours, got film=None")
    else:  # the film's exact unclipped lin_rec709 colours
        from rockdove.lut.reference import reference_colour

        colours = np.stack([np.asarray(reference_colour(preview_cos_theta, float(d), film, colour_space="lin_rec709"),
                                       np.float64) for d in tiles])
    paths = _texture_paths(out_dir)
    written = {"feather_preview": write_png(paths["feather_preview"], feather_preview_atlas(base, mask, colours))}
    if lut is not None:
        from rockdove.lut.exr import write_exr

        written["lut"] = write_exr(lut, paths["lut"])
    return dict(sorted(written.items()))
