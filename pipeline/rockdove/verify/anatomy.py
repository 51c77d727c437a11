"""The rock dove measured on the written asset, beside the published ranges: a change that breaks the bird's
silhouette, posture or colour pattern fails the verification.

Every measure reads the composed USD from disk (:func:`rockdove.render.scene.load_scene`: world space, metres;
reported in cm and degrees), by prim name (``Body``, ``HeadFeathers``, ``CoatFeathers``, ``Wings``, ``Tail``,
``Beak``, ``Cere``, ``Eyes``, ``EyeRings``, ``Legs``, ``Claws``) and the textures the parts' materials name, never
the generator's numbers. What is seen is found by ray casts through the alpha cut-outs, as the renderers see it
(:mod:`rockdove.verify.rays`).

Sources of the ranges: [G] Gibbs, Barnes and Cox, "Pigeons and Doves" (Pica Press 2001), as quoted by Wikipedia,
"Rock dove" (Description): length 29-37 cm, tail 9.5-11 cm (up to 12 allowed), bill about 1.8 cm, tarsus
2.6-3.5 cm; iris orange, red or golden, bare skin round the eye bluish-grey; bill grey-black with a conspicuous
off-white cere; white lower back, two black wing bars, a black band at the end of the tail. [I]
from side-view photographs of standing birds: body axis 30-45 degrees above the horizontal with the breast full
and forward, head about half the body's width and held up, tail reaching 3-6 cm beyond the folded wing tips,
wings flush with the body (never wider), tips meeting over the rump, toes on the ground, tibia in the contour.
[F] as a birder sees a rock dove (field guides: Gibbs et al.; Svensson et al., "Collins Bird Guide",
2009): a feathered head with only the eye's ring bare, two black bars crossing the folded wing, a broad closed
tail fan with depth (not a board), the pupil in the middle of the iris, dark claws; feather cards whose edges fade
(soft, partly transparent texels) rather than cut."""

from __future__ import annotations

import colorsys

import numpy as np

from ..errors import UsageError
from ..geometry.types import unit
from ..render.texture import read_texture, sample_texture
from ..srgb import linear_to_srgb8
from .rays import SceneGeometry, _first_opaque_hits
from .results import Anatomy, Measure

#: name -> (low, high, unit, source, what). None: unbounded on that side.
RANGES = {
    "total_length": (29.0, 37.0, "cm", "G", "bill tip to tail tip, straight"),
    "body_axis": (30.0, 45.0, "deg", "I", "tail base to neck base, above the horizontal"),
    "head_to_body_width": (0.40, 0.60, "", "I", "head width / body width (Body, both without cards)"),
    "head_above_back": (2.0, 12.0, "cm", "I", "eye height over the highest point of the back"),
    "breast_ahead_of_feet": (1.5, 8.0, "cm", "I", "breast front ahead of the ankles"),
    "tail_length": (9.5, 12.0, "cm", "G", "tip to the skin the central rectrices leave"),
    "tail_beyond_wings": (3.0, 6.0, "cm", "I", "tail tip beyond the folded wing tips"),
    "tail_band_contrast": (None, 0.5, "", "G", "luminance of the tail's last 12 % / its middle"),
    "wing_overhang": (None, 0.0, "cm", "I", "folded wings' half-width beyond the feathered body's"),
    "wing_tip_gap": (0.0, 2.5, "cm", "I", "distance between the two wing tips over the rump"),
    "tarsus_visible": (2.5, 3.5, "cm", "G", "ankle to where the leg enters the feathers"),
    "toes_ground": (-0.1, 0.1, "cm", "I", "lowest toe point above the ground (y = 0)"),
    "tibia_hidden": (0.0, None, "cm", "I", "depth of the legs' tops inside the body"),
    "bill_length": (1.5, 2.2, "cm", "G", "bill tip to the face"),
    "bill_luminance": (None, 0.1, "", "G", "bill's linear luminance (grey-black)"),
    "cere_luminance": (0.4, None, "", "G", "cere's linear luminance (off-white)"),
    "iris_hue": (0.0, 40.0, "deg", "G", "iris hue (sRGB HSV; orange-red)"),
    "eye_ring_width": (0.05, 0.3, "cm", "G", "bare orbital ring beyond the eye"),
    "eye_ring_saturation": (None, 0.3, "", "G", "orbital ring's saturation (grey)"),
    "rump_luminance": (0.5, None, "", "G", "lightest coat over the rump (white patch)"),
    "tail_width": (5.0, 9.0, "cm", "F", "tail fan's width across 85 % of its length"),
    "tail_depth": (0.8, 2.5, "cm", "F", "tail fan's depth (its arch and layers) across 85 % of its length"),
    "tail_base_depth": (1.5, 5.0, "cm", "F", "feathers' depth over and under the tail across 15 % of its length"),
    "head_feather_cover": (0.85, 1.0, "", "F", "share of the head's skin hidden by feathers (ring and bill aside)"),
    "wing_bar_count": (2, 2, "", "G", "black bands on the folded wing, seen from the side"),
    "wing_bar_angle": (35.0, 90.0, "deg", "F", "smallest angle between a wing bar and the wing's long axis"),
    "wing_bar_spread": (0.0, 20.0, "deg", "F", "angle between the two wing bars (they run side by side)"),
    "wing_bar_bow": (0.15, 1.5, "cm", "F", "least bow of a wing bar over its length (they curve)"),
    "soft_edge_share": (0.5, 1.0, "", "F", "share of card-edge texels partly transparent (0.1 < alpha < 0.9)"),
    "pupil_offset": (0.0, 0.15, "", "F", "pupil's centre off the eye's axis / eye radius"),
    "claw_luminance": (None, 0.1, "", "F", "claws' linear luminance (dark)"),
}
_LUM = np.array([0.2126, 0.7152, 0.0722])  # Rec.709 relative luminance of linear RGB


def _pts(scene, *names):
    return np.concatenate([p.positions_m for p in scene.parts if p.name in names]).astype(np.float64)


def _part(scene, name):
    for p in scene.parts:
        if p.name == name:
            return p
    raise UsageError(f"the asset has no mesh {name!r} (parts: {[p.name for p in scene.parts]})")


def _axis(points):
    c = points.mean(0)
    return c, np.linalg.svd(points - c, full_matrices=False)[2][0]


def _mesh(scene, *names):
    import trimesh

    parts = [_part(scene, n) for n in names]
    offs = np.cumsum([0] + [len(p.positions_m) for p in parts])
    return trimesh.Trimesh(np.concatenate([p.positions_m for p in parts]).astype(np.float64),
                           np.concatenate([p.triangles + o for p, o in zip(parts, offs)]), process=False)


def _first_hit(mesh, origin, direction) -> float:
    loc, ray, _ = mesh.ray.intersects_location(origin[None], direction[None], multiple_hits=True)
    d = (loc - origin) @ direction
    return float(d[d > 1e-6].min(initial=np.inf))


def _colours(part, n=4000, seed=0):
    """(m, 3) surface points and (m, 3) linear base colours sampled uniformly over a part (n samples, those where
    its texture's alpha is below the part's cut-out threshold left out: m <= n)."""
    p, t = part.positions_m.astype(np.float64), part.triangles
    tri = p[t]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    rng = np.random.default_rng(seed)
    f = rng.choice(len(t), n, p=area / area.sum())
    r1, r2 = np.sqrt(rng.random(n)), rng.random(n)
    w = np.stack([1 - r1, r1 * (1 - r2), r1 * r2], 1)
    pts = np.einsum("nk,nkd->nd", w, tri[f])
    if part.base_colour_texture is None:
        return pts, np.broadcast_to(part.base_colour, (n, 3)).astype(np.float64)
    st = np.einsum("nk,nkd->nd", w, part.st.astype(np.float64)[t[f]])
    img = np.asarray(sample_texture(read_texture(part.base_colour_texture, part.base_colour_srgb), st), np.float64)
    seen = img[:, -1] >= part.opacity_threshold if img.shape[1] in (2, 4) else np.ones(n, bool)
    return pts[seen], img[seen, :3]


def _hsv(linear):
    """(hue in degrees, saturation) of a linear colour as displayed (sRGB HSV)."""
    h, s, _ = colorsys.rgb_to_hsv(*np.asarray(linear_to_srgb8(np.asarray(linear, float)[None]), float)[0] / 255.0)
    return 360.0 * h, s


def _seen(geom, origins, directions):
    """(part index or -1, st) of the first opaque hits of rays from ``origins`` (N, 3) along ``directions``."""
    dirs = np.broadcast_to(np.asarray(directions, float), origins.shape)
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    face, _, bary = _first_opaque_hits(geom, np.asarray(origins, float), dirs, {})
    hit = np.maximum(face, 0)
    return np.where(face >= 0, geom.part_of_face[hit], -1), geom.interp(geom.st, hit, bary)


def _wing_bars(scene, geom, ta) -> tuple:
    """(count, smallest angle to the wing's axis (deg), largest angle between two bars (deg), least bow (m)) of
    the black bands of the left wing seen from the side: its texels darker than :data:`BAR_LUMINANCE` on a 1 mm
    grid, grouped 8-connected, groups over 0.5 cm^2; a bar's bow is its quadratic's sagitta over its length."""
    from scipy import ndimage

    wing = _part(scene, "Wings")
    w = wing.positions_m.astype(np.float64)[wing.positions_m[:, 0] > 0]
    (y0, z0), (y1, z1) = w[:, 1:].min(0), w[:, 1:].max(0)
    yy, zz = np.meshgrid(np.arange(y0, y1, 0.001), np.arange(z0, z1, 0.001), indexing="ij")
    part, st = _seen(geom, np.stack([np.full(yy.size, 0.2), yy.ravel(), zz.ravel()], 1), [-1.0, 0.0, 0.0])
    on = part == scene.parts.index(wing)
    lum = np.ones(yy.size)
    lum[on] = sample_texture(read_texture(wing.base_colour_texture, wing.base_colour_srgb), st[on])[:, :3] @ _LUM
    labels, n = ndimage.label((lum < BAR_LUMINANCE).reshape(yy.shape), np.ones((3, 3)))
    axis = np.array([ta[1], ta[2]]) / np.linalg.norm(ta[1:])  # the wing lies along the tail's line, side view
    bars, angles, bows = 0, [], []
    for k in range(1, n + 1):
        pts = np.stack([yy[labels == k], zz[labels == k]], 1)
        if len(pts) < 50:
            continue
        bars += 1
        d = np.linalg.svd(pts - pts.mean(0), full_matrices=False)[2][0]
        angles.append(np.degrees(np.arctan2(d @ [-axis[1], axis[0]], d @ axis)) % 180.0)
        t, r = (pts - pts.mean(0)) @ d, (pts - pts.mean(0)) @ [-d[1], d[0]]
        bows.append(abs(np.polyfit(t, r, 2)[0]) * (0.5 * np.ptp(t)) ** 2)
    across = [min(a, 180.0 - a) for a in angles]
    return bars, min(across, default=0.0), np.ptp(angles) if angles else 0.0, min(bows, default=0.0)


#: Texels darker than this (linear luminance) are a wing bar's black (the primaries' dark grey is above it).
BAR_LUMINANCE = 0.035


def measures(scene) -> dict:
    """Every measure of :data:`RANGES` on a :class:`rockdove.render.scene.RenderScene`: name -> value."""
    import trimesh

    body = _part(scene, "Body")
    bp = body.positions_m.astype(np.float64)
    trunk = bp[body.neck_s <= 0.0] if body.neck_s is not None else bp
    feathered = _pts(scene, "Body", "CoatFeathers")
    wings, tail, legs = _pts(scene, "Wings"), _pts(scene, "Tail"), _pts(scene, "Legs")
    beak, eyes, rings = _pts(scene, "Beak"), _pts(scene, "Eyes"), _pts(scene, "EyeRings")
    m = {}
    tc, ta = _axis(tail)
    ta = ta if ta[2] < 0 else -ta  # pointing away from the body
    tail_proj = (tail - tc) @ ta
    neck_base = bp[(body.neck_s > 0.0) & (body.neck_s < 0.08)].mean(0)
    a = neck_base - (tc + tail_proj.min() * ta)
    m["body_axis"] = np.degrees(np.arctan2(a[1], np.hypot(a[0], a[2])))
    tail_tip = tail[np.argmax(tail_proj)]
    bill_tip = beak[np.argmax(beak[:, 2])]
    m["total_length"] = 100 * np.linalg.norm(bill_tip - tail_tip)
    up = np.cross(np.cross(ta, [0.0, 1.0, 0.0]), ta)  # the tail's upper side
    m["tail_length"] = 100 * _first_hit(_mesh(scene, "Body"), tail_tip + 0.002 * up / np.linalg.norm(up), -ta)
    m["tail_beyond_wings"] = 100 * (tail_proj.max() - ((wings - tc) @ ta).max())
    tips = [w[np.argmax((w - tc) @ ta)] for w in (wings[wings[:, 0] > 0], wings[wings[:, 0] < 0])]
    m["wing_tip_gap"] = 100 * np.linalg.norm(tips[0] - tips[1])
    m["wing_overhang"] = 100 * (np.abs(wings[:, 0]).max() - np.abs(feathered[:, 0]).max())
    eye_mid = eyes.mean(0)
    head = bp[(bp[:, 1] > eye_mid[1] - 0.012) & (np.linalg.norm(bp - eye_mid, axis=1) < 0.035)]
    m["head_to_body_width"] = np.ptp(head[:, 0]) / np.ptp(bp[:, 0])
    m["head_above_back"] = 100 * (eye_mid[1] - trunk[:, 1].max())
    ankles = [legs[(s * legs[:, 0] > 0) & (legs[:, 1] < legs[:, 1].min() + 0.004)].mean(0) for s in (1, -1)]
    m["breast_ahead_of_feet"] = 100 * (trunk[:, 2].max() - np.mean([k[2] for k in ankles]))
    names = {p.name for p in scene.parts}
    cover = _mesh(scene, *[n for n in ("Body", "CoatFeathers", "Wings", "Tail") if n in names])
    closed = trimesh.Trimesh(bp, body.triangles, process=False)
    vis, depth = [], []
    for s, ankle in zip((1, -1), ankles):
        side = legs[(s * legs[:, 0] > 0) & (legs[:, 1] > 0.01)]
        c, d = _axis(side)
        d = d if d[1] > 0 else -d
        base = c + ((ankle - c) @ d) * d
        vis.append(_first_hit(cover, base, d))
        top = side[np.argmax(side @ d)]
        depth.append(float(trimesh.proximity.signed_distance(closed, top[None])[0]))
    m["tarsus_visible"] = 100 * float(np.mean(vis))
    m["tibia_hidden"] = 100 * min(depth)
    m["toes_ground"] = 100 * legs[:, 1].min()
    back = eye_mid - bill_tip
    m["bill_length"] = 100 * _first_hit(_mesh(scene, "Body"), bill_tip, back / np.linalg.norm(back))
    for name, key in (("Beak", "bill_luminance"), ("Cere", "cere_luminance")):
        m[key] = float(_part(scene, name).base_colour @ _LUM)
    m["iris_hue"] = _hsv(_part(scene, "Eyes").base_colour)[0]
    m["eye_ring_saturation"] = _hsv(_part(scene, "EyeRings").base_colour)[1]
    widths = []
    for s in (1, -1):
        e, r = eyes[s * eyes[:, 0] > 0], rings[s * rings[:, 0] > 0]
        c = e.mean(0)
        widths.append(np.linalg.norm(r - c, axis=1).max() - np.linalg.norm(e - c, axis=1).max())
    m["eye_ring_width"] = 100 * float(np.mean(widths))
    pts, col = _colours(_part(scene, "Tail"))
    f = ((pts - tc) @ ta - tail_proj.min()) / np.ptp(tail_proj)
    lum = col @ _LUM
    m["tail_band_contrast"] = float(lum[f > 0.88].mean() / max(lum[(f > 0.3) & (f < 0.7)].mean(), 1e-6))
    pts, col = _colours(_part(scene, "CoatFeathers"), 20000)
    root = tc + tail_proj.min() * ta
    rump = (np.abs(pts[:, 0]) < 0.02) & (pts[:, 1] > root[1]) & (pts[:, 2] > root[2]) & (pts[:, 2] < root[2] + 0.05)
    m["rump_luminance"] = float(np.percentile(col[rump] @ _LUM, 95)) if rump.any() else 0.0
    fan = _colours(_part(scene, "Tail"), 20000)[0]  # surface samples: dense in every cross-section
    under = np.concatenate([fan, _colours(_part(scene, "CoatFeathers"), 40000)[0]])
    for key, (f, which) in {"tail_width": (0.85, fan), "tail_depth": (0.85, fan),
                            "tail_base_depth": (0.15, under)}.items():
        q = (which - tc) @ ta - tail_proj.min()
        sec = which[np.abs(q - f * np.ptp(tail_proj)) < 0.003]
        m[key] = 100 * np.ptp(sec @ ([1.0, 0.0, 0.0] if key == "tail_width" else up / np.linalg.norm(up))) if len(
            sec) else float("nan")
    geom = SceneGeometry(scene)  # one set of ray-cast structures and textures for the two measures that look
    m["wing_bar_count"], m["wing_bar_angle"], m["wing_bar_spread"], bow = _wing_bars(scene, geom, ta)
    m["wing_bar_bow"] = 100 * bow
    m["head_feather_cover"] = _head_cover(scene, geom, body, eye_mid, rings, beak)
    m["soft_edge_share"] = _soft_edges(_part(scene, "CoatFeathers").base_colour_texture)
    m["pupil_offset"] = _pupil_offset(_part(scene, "Eyes"), eyes)
    m["claw_luminance"] = float(_part(scene, "Claws").base_colour @ _LUM)
    return {k: float(v) for k, v in m.items()}


def _head_cover(scene, geom, body, eye_mid, rings, beak) -> float:
    """Share of the head's skin (above the eyes' level less 1.2 cm, the ring and 4 mm round the bill aside) whose
    ray from 2 cm out along its normal first meets a feather, not the skin."""
    p, n = body.positions_m.astype(np.float64), body.normals.astype(np.float64)
    head = (body.neck_s >= 1.0) & (p[:, 1] > eye_mid[1] - 0.012)
    for pts, gap in ((rings, 0.001), (beak, 0.004)):
        head &= np.min([np.linalg.norm(p - q, axis=1) for q in pts[:: max(1, len(pts) // 200)]], axis=0) > gap
    idx = np.flatnonzero(head)[:: max(1, head.sum() // 1500)]
    part, _ = _seen(geom, p[idx] + 0.02 * n[idx], -n[idx])
    feathered = [i for i, q in enumerate(scene.parts) if q.name == "HeadFeathers"]
    return float(np.isin(part, feathered).mean()) if len(idx) else 0.0


def _soft_edges(texture) -> float:
    """Share of the cut-out's edge texels (alpha crossing 0.5 within their 3 x 3) that are partly transparent."""
    from scipy import ndimage

    a = read_texture(texture, False)[..., -1]
    edge = (ndimage.maximum_filter(a, 3) >= 0.5) & (ndimage.minimum_filter(a, 3) < 0.5)
    return float(((a[edge] > 0.1) & (a[edge] < 0.9)).mean()) if edge.any() else 0.0


def _pupil_offset(part, eyes) -> float:
    """How far the pupil (texels darker than 0.02 within 45 degrees of the iris's middle) is off the middle of the
    iris (orange texels) on each eyeball: the distance between the directions from the eye's centre to their
    centroids, in eye radii; the larger of the two eyes (1 without a pupil)."""
    pts, col = _colours(part, 8000)
    lum, out = col @ _LUM, []
    for s in (1, -1):
        side = s * pts[:, 0] > 0
        c = eyes[s * eyes[:, 0] > 0].mean(0)
        iris = side & (col[:, 0] > 2 * col[:, 2] + 0.05)
        middle = unit(pts[iris].mean(0) - c) if iris.any() else np.zeros(3)
        dark = side & (lum < 0.02) & (unit(pts - c) @ middle > np.cos(np.pi / 4))
        if not dark.any():
            return 1.0
        out.append(np.linalg.norm(unit(pts[dark].mean(0) - c) - middle))
    return float(max(out))


def check(values: dict) -> Anatomy:
    """Each measure of ``values`` (name -> value, :func:`measures`) against its range in :data:`RANGES`."""
    rows, failures = [], []
    for name, (lo, hi, units, src, what) in RANGES.items():
        v = values.get(name, float("nan"))
        ok = bool(np.isfinite(v) and (lo is None or v >= lo) and (hi is None or v <= hi))
        rows.append(Measure(name, round(v, 3), lo, hi, units, src, what, ok))
        if not ok:
            failures.append(f"anatomy: {name} = {v:.3g} {units} outside [{lo}, {hi}] ({what})".replace("  ", " "))
    return Anatomy(not failures, tuple(failures), tuple(rows))


def measure_scene(scene) -> Anatomy:
    """:func:`check` of :func:`measures`; an asset without the bird's parts fails with the reason, not a crash."""
    try:
        return check(measures(scene))
    except (ValueError, IndexError) as exc:
        return Anatomy(False, (f"anatomy: cannot measure the asset: {exc}",))


def format_rows(result: Anatomy) -> list[str]:
    """One line per measure: name, value (a NaN read back from report.json is None), range, pass/fail."""
    return [f"{r.name:>22}: {np.nan if r.value is None else r.value:8.3f} {r.unit:<3} {rng:<14} "
            f"{'ok' if r.passed else 'FAIL'}  ({r.what})"
            for r in result.measures
            for rng in [f"[{'' if r.low is None else r.low}, {'' if r.high is None else r.high}]"]]
