"""Verification of the hosts (:mod:`rockdove.hosts`): each host's renders against the exact reference of the
lighting model it evaluates, over the reference's structural feather pixels (eroded by one pixel as the GL
comparison does; a host returns radiance only, no part ids, so its silhouette is the reference's).

``median_dE``, ``p95_dE``: CIEDE2000 of the unclipped linear radiance; ``green_px``, ``purple_px``: host pixels in
the strict hue bands; ``hue_agreement``: share of pixels whose class (green, purple, other) is the reference's.

Pass (:func:`host_passed`): networks that claim the exact colour (``glsl``, ``baked``) meet the dE goals
(median <= :data:`rockdove.verify.compare.MEDIAN_DE_GOAL`, p95 <= :data:`~rockdove.verify.compare.P95_DE_GOAL`);
a host's own thin-film BSDF (``physical``), an approximation, shows green and purple and agrees on the hue
class of >= :data:`MIN_HUE_AGREEMENT` of the pixels (its dE is reported, not held to the goal)."""

from __future__ import annotations

import logging
import os

import numpy as np

from ..errors import UsageError
from . import compare
from .results import DeStats, HostMetrics, HostResult

_log = logging.getLogger(__name__)

#: Share of feather-tip pixels whose green/purple/other class must match the reference (physical variants).
MIN_HUE_AGREEMENT = 0.85
#: Variants held to the dE goals.
EXACT_VARIANTS = ("glsl", "baked")
#: Variants checked for green and purple only: the UsdPreviewSurface atlas (one angle per thickness).
PRESENCE_VARIANTS = ("preview",)


def _classes(lab: np.ndarray) -> np.ndarray:
    cls = compare.lab_hue_classes(lab)[2]
    return np.where((cls == 1) | (cls == 2), cls, 3).astype(np.int8)


def _de_stats(de: np.ndarray) -> DeStats:
    n, nan = int(de.size), float("nan")
    return DeStats(n, float(np.median(de)) if n else nan, float(np.percentile(de, 95)) if n else nan)


def host_metrics(images: dict, refs: list, scene) -> tuple[HostMetrics, dict]:
    """dE and hue statistics of one host's renders (``images``: view -> (H, W, 3) linear radiance) against ``refs``
    (its lobe's, one per view), and the dE maps by view; ValueError for a view missing or of the wrong shape."""
    feather_ids = compare.feather_ids(scene)
    des, host_cls, ref_cls, per_view, maps = [], [], [], {}, {}
    for ref in refs:
        if ref.view not in images:
            raise UsageError(f"the host returned no image for view {ref.view!r}; it returned {sorted(images)}")
        img = np.asarray(images[ref.view], np.float64)
        if img.shape != ref.rgb.shape:
            raise UsageError(f"view {ref.view!r}: host image {img.shape}, expected {ref.rgb.shape}")
        img = np.where(np.isfinite(img), img, 0.0)
        sel = compare.comparison_mask(ref.part_id, ref.part_id, feather_ids, 1) & (ref.mask >= compare.STRUCTURAL_MASK)
        vals, lab = compare.pixel_de(img[sel], ref.rgb[sel])
        maps[ref.view] = np.full(sel.shape, np.nan)
        maps[ref.view][sel] = vals
        des.append(vals)
        host_cls.append(_classes(lab))
        ref_cls.append(_classes(compare.rgb_to_lab(ref.rgb[sel])))
        per_view[ref.view] = _de_stats(vals)
    de, hc, rc = np.concatenate(des), np.concatenate(host_cls), np.concatenate(ref_cls)  # refs: one per view, >= 1
    return HostMetrics(**vars(_de_stats(de)), green_px=int(np.sum(hc == 1)), purple_px=int(np.sum(hc == 2)),
                       hue_agreement=float(np.mean(hc == rc)) if de.size else float("nan"), per_view=per_view), maps


def host_passed(variant: str, m: HostMetrics) -> tuple[bool, list]:
    """Whether a host's metrics meet its goals (module docstring); ``(passed, reasons it failed)``."""
    why = []
    if m.n_pixels == 0:
        return False, ["no feather-tip pixels to compare"]
    if variant in EXACT_VARIANTS:
        if not m.median_dE <= compare.MEDIAN_DE_GOAL:
            why.append(f"median dE2000 {m.median_dE:.3f} > {compare.MEDIAN_DE_GOAL}")
        if not m.p95_dE <= compare.P95_DE_GOAL:
            why.append(f"p95 dE2000 {m.p95_dE:.3f} > {compare.P95_DE_GOAL}")
    else:
        why += [f"no {hue} feather pixels" for hue, px in (("green", m.green_px), ("purple", m.purple_px)) if not px]
        if variant not in PRESENCE_VARIANTS and not m.hue_agreement >= MIN_HUE_AGREEMENT:
            why.append(f"hue class agrees with the reference on {m.hue_agreement:.1%} of the feather-tip "
                       f"pixels < {MIN_HUE_AGREEMENT:.0%}")
    return not why, why


def check_host(host, asset_layer: str, scene, views, refs: list, out_dir: str, rendered) -> HostResult:
    """Render the views in one host (unless ``rendered``: the GL renders for ``glsl``), compare them with ``refs``
    and write the images into ``out_dir``: a :class:`HostResult` (``error`` for a HostError; ``skipped`` when its
    ``cannot_draw(asset_layer)`` says why)."""
    from ..hosts.base import HostError
    from ..png import save_png
    from ..srgb import linear_to_srgb8
    from . import report as rep

    name, variant, lobe = host.name, host.variant, host.lobe
    reason = host.cannot_draw(asset_layer) if rendered is None else None
    if reason:
        return HostResult(name, "skipped", variant, lobe, reason)
    try:
        if rendered is None:
            _log.info(f"host {name} ({variant}, {lobe}): rendering {len(views)} views")
            rendered = host.render(asset_layer, list(views), out_dir)
        m, maps = host_metrics(rendered, refs, scene)
    except (HostError, ValueError) as exc:
        return HostResult(name, "error", variant, lobe, str(exc))
    passed, why = host_passed(variant, m)
    files = {}
    for ref in refs:
        files[ref.view] = {"host": f"{ref.view}_{name}.png", "reference": f"{ref.view}_{lobe}_reference.png",
                           "dE": f"{ref.view}_{name}_dE.png"}
        host_png, ref_png, de_png = (os.path.join(out_dir, f) for f in files[ref.view].values())
        save_png(linear_to_srgb8(rendered[ref.view]), host_png)
        save_png(linear_to_srgb8(ref.rgb), ref_png)
        rep.de_map_png(de_png, maps[ref.view], f"{name} {ref.view}: dE2000 median {m.per_view[ref.view].median_dE:.2f}")
    return HostResult(name, "passed" if passed else "failed", variant, lobe, "; ".join(why) or None, m, tuple(why),
                      files)
