"""The verification report, in one folder with relative file names (``report.html`` opens from disk, no server):
the views' renders and dE2000 maps, ``contact_sheet.png``, ``lut.png``, ``spectra.png``, ``hue.png``,
``light_turn.webp``, ``bench_*.png`` (``rockdove verify --bench-dir DIR``), ``report.json`` and ``report.html``.

The dE maps are drawn with Pillow; the charts with matplotlib's object API (``Figure`` + ``FigureCanvasAgg``),
which needs no display and leaves pyplot's global state alone."""

from __future__ import annotations

import html
import json
import math
import os
import re
import shutil
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..png import save_png
from ..render.images import contact_sheet as tile_sheet
from ..render.images import label_font
from ..spectral import Lab_to_XYZ, XYZ_to_RGB
from ..srgb import linear_to_srgb8, srgb_encode

if TYPE_CHECKING:
    from .compare import HueHistogram
    from .results import Report

#: Colour-bar range of the dE2000 maps (the p95 goal is 2; everything above 5 saturates).
DE_MAP_MAX = 5.0
DE_COLORMAP = "magma"


def _figure(w_in, h_in, margins_in, rows: int = 1, gap_in: float = 0.0):
    """A Figure on an Agg canvas, its subplots placed by fixed margins ``(left, right, bottom, top)`` and a ``gap_in``
    between ``rows``, in inches at 100 dpi (``tight_layout`` would draw the figure once more to measure labels)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w_in, h_in), dpi=100)
    FigureCanvasAgg(fig)
    left, right, bottom, top = margins_in
    axes_h = (h_in - bottom - top - (rows - 1) * gap_in) / rows
    fig.subplots_adjust(left=left / w_in, right=1.0 - right / w_in, bottom=bottom / h_in, top=1.0 - top / h_in,
                        hspace=gap_in / axes_h)
    return fig


def _save_figure(fig, path) -> str:
    """Draw ``fig`` once and write it with :func:`rockdove.png.save_png`, the display PNGs' writer."""
    fig.canvas.draw()
    return save_png(np.asarray(fig.canvas.buffer_rgba())[..., :3], path)


def de_colour(de_map, vmax: float = DE_MAP_MAX) -> np.ndarray:
    """(H, W) dE map -> (H, W, 3) uint8 with the :data:`DE_COLORMAP`, NaN (not compared) mid grey: the colormap's own
    lookup (``Colormap.__call__`` on floats: entry ``floor(x N)``, x = 1 the last) on a uint8 copy of its table."""
    from matplotlib import colormaps

    cmap = colormaps[DE_COLORMAP]
    table = np.vstack([(cmap(np.arange(cmap.N))[:, :3] * 255).round(), [96, 96, 96]]).astype(np.uint8)
    de = np.asarray(de_map, np.float64)
    x = np.clip(np.nan_to_num(de, nan=0.0) / vmax, 0.0, 1.0)
    index = np.where(np.isfinite(de), np.minimum((x * cmap.N).astype(np.intp), cmap.N - 1), cmap.N)
    return np.take(table, index, axis=0)


DE_BAR_LABEL = "dE2000 (grey: not compared)"


def de_map_png(path, de_map, title: str) -> str:
    """The dE2000 map under its title, beside a colour bar from 0 to :data:`DE_MAP_MAX`, as PNG: the map's pixels one
    to one (every compared pixel as measured), text sized to the map (legible when the report scales it down)."""
    from PIL import Image, ImageDraw

    de = np.asarray(de_map, np.float64)
    h, w = de.shape
    f = max(12, round(max(h, w) / 36))  # text height, px
    pad, header, gap, bar_w, tick = max(2, f // 2), round(1.8 * f), f, max(8, round(0.9 * f)), max(3, f // 3)
    font = label_font(f)
    whole = (h - 1) / DE_MAP_MAX >= 1.5 * f  # a tick every whole dE, or only the ends where labels would touch
    ticks = np.arange(0.0, math.floor(DE_MAP_MAX) + 1.0) if whole else np.array([0.0, DE_MAP_MAX])
    labels = [f"{t:g}" for t in ticks]
    bar_x = pad + w + gap
    text_x = bar_x + bar_w + tick + max(2, f // 4)
    name_x = text_x + round(max(font.getlength(t) for t in labels)) + pad
    # the bar's name, rotated to read bottom to top, shrunk towards the bar's height (the image grows below a
    # small map rather than the name shrinking past legibility)
    name_font = label_font(max(10, min(f, int(f * h / (font.getlength(DE_BAR_LABEL) + 2 * pad)))))
    box = name_font.getbbox(DE_BAR_LABEL)
    name = Image.new("RGB", (box[2] + 2, box[3] + 2), "white")
    ImageDraw.Draw(name).text((1, 1), DE_BAR_LABEL, fill="black", font=name_font)
    name = name.rotate(90, expand=True)
    width = name_x + name.width + pad
    sheet = Image.new("RGB", (width, header + max(h, name.height) + pad), "white")
    draw = ImageDraw.Draw(sheet)
    title_font = font if font.getlength(title) <= width - 2 * pad else label_font(
        int(f * (width - 2 * pad) / font.getlength(title)))
    draw.text((pad, header // 2), title, fill="black", font=title_font, anchor="lm")
    ramp = np.repeat(np.linspace(DE_MAP_MAX, 0.0, h)[:, None], bar_w, axis=1)
    for x0, img in ((pad, de_colour(de)), (bar_x, de_colour(ramp))):
        draw.rectangle((x0 - 1, header - 1, x0 + img.shape[1], header + h), outline="black")
        sheet.paste(Image.fromarray(img), (x0, header))
    for t, label in zip(ticks, labels):
        y = header + round((1.0 - t / DE_MAP_MAX) * (h - 1))
        draw.line((bar_x + bar_w, y, bar_x + bar_w + tick, y), fill="black")
        draw.text((text_x, y), label, fill="black", font=font, anchor="lm")
    sheet.paste(name, (name_x, header + max(0, h - name.height) // 2))
    return save_png(np.asarray(sheet), path)


#: What each column of a verification contact-sheet row shows (rockdove.verify.run: GL, reference, dE map).
SHEET_COLUMNS = ("GLSL", "reference", f"dE2000 0-{DE_MAP_MAX:g}")


def contact_sheet(path, rows) -> str:
    """The contact sheet: a row per view, ``(label, [GL, reference, dE map])``, tiles titled by their column."""
    titled = []
    for label, imgs in rows:
        titles = [SHEET_COLUMNS[c] if c < len(SHEET_COLUMNS) else "" for c in range(len(imgs))]
        titles[0] = f"{label}  {titles[0]}".strip()
        titled.append([(t, np.asarray(img)[..., :3]) for t, img in zip(titles, imgs)])
    return tile_sheet(path, titled)


def lut_png(path, lut) -> str:
    """The LUT as the display shows it, over its real axes (cos theta on x, thickness on y)."""
    img = linear_to_srgb8(lut.rgb)  # row 0 = thinnest
    fig = _figure(6.0, 3.6, (0.85, 0.3, 0.6, 0.35))
    ax = fig.add_subplot(1, 1, 1)
    lo, hi = lut.thickness_range_nm
    if hi == lo:
        lo, hi = lo - 5.0, hi + 5.0
    ax.imshow(img, origin="lower", aspect="auto", extent=(0.0, 1.0, lo, hi), interpolation="nearest")
    ticks = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    ax.set_xticks(ticks, [f"{t ** lut.angle_warp_gamma:.2f}" for t in ticks])
    ax.set(xlabel=f"cos theta (warped axis, gamma = {lut.angle_warp_gamma:g})", ylabel="film thickness (nm)")
    ax.set_title(f"LUT {lut.n_thickness} x {lut.n_angle}, {lut.colour_space} (display: clipped sRGB)", fontsize=9)
    return _save_figure(fig, path)


def spectra_png(path, film, thickness_nm=(480.0, 650.0, 700.0), cos_theta=(1.0, 0.707, 0.3, 0.05)) -> str:
    """Reflectance spectra of the asset's film (exact Airy, 0.1 nm) for a few thicknesses and angles."""
    from .. import optics
    from ..lut.reference import reference_wavelengths

    wl, m = reference_wavelengths(), film.model
    fig = _figure(7.0, 2.6 * len(thickness_nm), (0.7, 0.3, 0.6, 0.35), rows=len(thickness_nm), gap_in=0.58)
    for i, d in enumerate(thickness_nm):
        ax = fig.add_subplot(len(thickness_nm), 1, i + 1)
        for c in cos_theta:
            r = optics.reflectance(wl, c, d, n_film=m.n_film(wl), n_incident=m.n_incident, n_substrate=m.n_substrate)
            ax.plot(wl, r, lw=0.8, label=f"cos theta = {c:g}")
        ax.set(ylabel="R", ylim=(0, 1))
        ax.set_title(f"d = {d:g} nm, {m.name}: n = {m.cauchy_a:g} + {m.cauchy_b_nm2:g} / lambda^2", fontsize=9)
        if i == 0:
            ax.legend(fontsize=7, loc="upper right")
    ax.set_xlabel("wavelength (nm)")
    return _save_figure(fig, path)


def hue_png(path, hue: HueHistogram, title: str) -> str:
    """Bar chart of a :func:`rockdove.verify.compare.hue_histogram`, bars coloured by their hue."""
    edges = np.asarray(hue.bin_edges_deg)
    centres = 0.5 * (edges[:-1] + edges[1:])
    lab = np.stack([np.full_like(centres, 60.0), 40 * np.cos(np.radians(centres)), 40 * np.sin(np.radians(centres))], 1)
    rgb = srgb_encode(np.clip(XYZ_to_RGB(Lab_to_XYZ(lab), "lin_rec709"), 0.0, 1.0))  # the bins' own hues, displayed
    fig = _figure(6.0, 3.0, (1.0, 0.2, 0.6, 0.35))  # left: room for 6-digit counts (matplotlib goes to 1e6 above)
    ax = fig.add_subplot(1, 1, 1)
    ax.bar(centres, hue.counts, width=np.diff(edges) * 0.9, color=np.clip(rgb, 0, 1), edgecolor="k", lw=0.3)
    for band, name in ((hue.green_band_deg, "green"), (hue.purple_band_deg, "purple")):
        ax.axvline(band[0], color="k", ls=":", lw=0.8)
        ax.text(band[0] + 2, ax.get_ylim()[1] * 0.9, name, fontsize=7)
    ax.set(xlim=(0, 360), xlabel="CIELAB hue angle h_ab (deg)", ylabel="pixels")
    ax.set_title(f"{title}: green {hue.green}, purple {hue.purple}, grey {hue.grey}, other {hue.other}",
                 fontsize=8)
    return _save_figure(fig, path)


def copy_bench_plots(out_dir, bench_dir) -> list[str]:
    """Copy ``bench_dir/*.png`` into ``out_dir`` as ``bench_<name>.png``; returns the new file names."""
    found = sorted(os.listdir(bench_dir)) if bench_dir and os.path.isdir(bench_dir) else []
    names = [name for name in found if name.lower().endswith(".png")]
    for name in names:
        shutil.copyfile(os.path.join(bench_dir, name), os.path.join(out_dir, f"bench_{name}"))
    return [f"bench_{name}" for name in names]


def strict_json(obj):
    """``obj`` as plain JSON data: numpy values to Python, anything else unknown to str, NaN/Inf to None."""
    plain = json.dumps(obj, default=lambda o: o.tolist() if isinstance(o, (np.generic, np.ndarray)) else str(o))
    return json.loads(plain, parse_constant=lambda name: None)


def portable(obj, roots):
    """``obj`` with the build machine's paths taken out, for the files a report ships: a path inside one of
    ``roots`` (the asset folder, staged and published) relative to it, any other absolute path on this machine
    (its first folder exists here; USD prim paths such as ``/Pigeon/Geom`` do not) as its file name."""
    prefixes = sorted({os.path.abspath(r).rstrip(os.sep) for r in roots}, key=len, reverse=True)

    def local(m):
        p = m.group(0)
        inside = [r for r in prefixes if p == r or p.startswith(r + os.sep)]
        return os.path.relpath(p, inside[0]) if inside else os.path.basename(p) if os.path.isdir(
            os.sep + p.split(os.sep)[1]) else p

    def fix(v):
        if isinstance(v, dict):
            return {k: fix(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [fix(x) for x in v]
        return re.sub(r"(?<![\w.@:])/[^\s'\"<>@\]\[,;)(]+", local, v) if isinstance(v, str) else v
    return fix(obj)


def write_json(path, report: dict) -> str:
    """Write the report as strict JSON (NaN -> null), sorted keys, 2-space indent."""
    with open(path, "w", encoding="utf-8") as f:
        json.dump(strict_json(report), f, indent=2, sort_keys=True, allow_nan=False)
        f.write("\n")
    return os.fspath(path)


def _fmt(v, digits=3):
    if isinstance(v, float):
        return "n/a" if not math.isfinite(v) else f"{v:.{digits}f}"
    return html.escape(str(v))


def _list(title: str, items) -> str:
    return (f"<h2>{title}</h2><ul>" + "".join(f"<li>{html.escape(str(i))}</li>" for i in items) + "</ul>"
            if items else "")


def _head(*names) -> str:
    return "<table><tr>" + "".join(f"<th>{n}</th>" for n in names) + "</tr>"


def _row(name: str, *cells) -> str:
    cells = "".join(f"<td>{c}</td>" for c in cells)
    return f"<tr><td style='text-align:left'>{html.escape(name)}</td>{cells}</tr>"


def _pairs(title: str, values: dict, fmt) -> str:
    e = html.escape
    return (f"<h2>{title}</h2><table>" + "".join(f"<tr><th style='text-align:left'>{e(k)}</th><td>{fmt(v)}</td></tr>"
                                                  for k, v in values.items()) + "</table>" if values else "")


def _figure_row(title: str, files: dict, captions: dict) -> str:
    """One report row: a heading and, for each key of ``captions`` that ``files`` names, the image captioned."""
    e = html.escape
    figs = "".join(f"<figure><img src='{e(files[k])}' alt='{e(title)} {e(k)}'><figcaption>{e(c)}</figcaption>"
                   f"</figure>" for k, c in captions.items() if files.get(k))
    return f"<h3>{e(title)}</h3><div class='row'>{figs}</div>"


@dataclass
class Figures:
    """The report's image files, relative to the page: ``views`` ``{view: {"gl", "reference", "dE": file}}``,
    ``hosts`` ``{host: {view: {"host", "reference", "dE": file}}}``, the charts, pictures and viewer page."""

    views: dict = field(default_factory=dict)
    hosts: dict = field(default_factory=dict)
    contact_sheet: str | None = None
    lut: str | None = None
    spectra: str | None = None
    hue: str | None = None
    bench: list = field(default_factory=list)
    beauty: dict | None = None
    animation: dict | None = None
    viewer: str | None = None


def _beauty(images: Figures) -> str:
    """The picture the page opens with (:func:`rockdove.hosts.beauty.for_report`): its views, its caption."""
    b = images.beauty
    if not b:
        return ""
    e = html.escape
    figs = "".join(f"<figure><img src='{e(f)}' alt='beauty render, {e(name)}' style='image-rendering:auto'></figure>"
                   for name, f in b["files"].items())
    return f"<div class='row'>{figs}</div><p><small>Beauty render: {e(b['caption'])}</small></p>"


def _animation(images: Figures) -> str:
    """The light-turning animation (:func:`rockdove.render.animation.for_report`): the WebP plays inline."""
    a, e = images.animation, html.escape
    return (f"<h2>The shimmer moving</h2><figure><img src='{e(a['files']['light_turn'])}' alt='the light turning "
            f"round the bird' style='image-rendering:auto'><figcaption>{e(a['caption'])}</figcaption></figure>"
            if a else "")


def write_html(path, report: Report, images: Figures) -> str:
    """A self-contained page (relative image links) summarising ``report`` with its ``images``."""
    e = html.escape
    status, colour = ("PASSED", "#1a7f37") if report.passed else ("FAILED", "#b42318")
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>rockdove verification</title>",
        "<style>body{font-family:sans-serif;margin:1.5em;max-width:1200px}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#eee}"
        "img{max-width:100%;image-rendering:pixelated}.row{display:flex;gap:8px}.row figure{margin:0;flex:1}"
        "figcaption{font-size:100%;color:#222}h1{font-size:1.6em}"
        ".viewer{width:100%;height:600px;border:1px solid #ccc}</style></head><body>",
        f"<h1>rockdove verification: <span style='color:{colour}'>{status}</span></h1>" + _beauty(images)
        + _animation(images) + _list("Notes", report.notes),
        f"<p>Asset: <code>{e(report.asset)}</code><br>",
        f"Configuration hash: <code>{e(str(report.configuration_hash or 'not recorded'))}</code><br>",
        f"Goals: median dE2000 &le; {report.goals.median_dE}, "
        f"p95 &le; {report.goals.p95_dE} over feather pixels away from silhouette edges.</p>",
    ]
    if images.viewer:  # the interactive view first, the tables after it
        parts.append(f"<h2>Interactive view</h2><p>Drag to orbit, wheel to zoom, slide to turn the light; switch "
                     f"between the paper's baked LUT (our GLSL in WebGL2) and three.js's KHR_materials_iridescence "
                     f"shading of pigeon.glb. <a href='{e(images.viewer)}'>Open it full size</a>.</p>"
                     f"<iframe class='viewer' src='{e(images.viewer)}' title='interactive view'></iframe>")
    hero = images.views.get("hero", {})
    if hero.get("gl") or hero.get("reference"):
        parts.append(f"<h2>Hero view</h2><img src='{e(hero.get('gl') or hero.get('reference'))}' alt='hero view' "
                     "style='image-rendering:auto'>")
    if report.motion:  # the motion's measures beside their limits (rockdove.verify.motion)
        mo = report.motion
        parts.append(_pairs(f"Motion {e(mo.motion)}: measured at {mo.frames} time codes, film checked at "
                            f"{', '.join(f'{t:g}' for t in mo.times)}", {k: f"{_fmt(v, 5)} (limit "
                            f"{mo.limits.get(k, '-')})" for k, v in mo.measures.items()}, str))
        if a := mo.animation:
            parts.append(f"<figure><img src='{e(a['file'])}' alt='{e(mo.motion)}'><figcaption>{e(a['caption'])}"
                         "</figcaption></figure>")
    parts.append(_list("Failures", report.failures))
    parts.append("<h2>Per view</h2>" + _head("view", "pixels", "median dE", "p95 dE", "max dE", "&gt; 2", "black",
                                            "green", "purple", "passed"))
    parts += [_row(m.view, m.n_pixels, _fmt(m.de_median), _fmt(m.de_p95), _fmt(m.de_max),
                   _fmt(m.de_fraction_over_p95_goal, 4), f"{m.n_black}/{m.n_lit}", m.hue.green, m.hue.purple,
                   "yes" if m.passed else "no") for m in report.views]
    parts.append("</table>")
    parts.append("<h2>Green/purple boundary straightness</h2><p>RMS perpendicular distance of the boundary pixels "
                 "from their total-least-squares line (paper preset: straight; measured preset: bent).</p>"
                 + _head("view", "points", "RMS (px)", "length (px)", "RMS / length"))
    parts += [_row(name, s.n_points, _fmt(s.rms_px), _fmt(s.length_px, 1), _fmt(s.rms_fraction, 4))
              for name, s in report.boundary.per_view.items()]
    parts.append("</table>")
    for key, title in (("hue", "Hue histogram across the light sweep"), ("contact_sheet", "Contact sheet"),
                       ("lut", "The LUT"), ("spectra", "Film reflectance spectra")):
        if getattr(images, key):
            parts.append(f"<h2>{e(title)}</h2><img src='{e(getattr(images, key))}' alt='{e(key)}'>")
    if report.hosts:
        parts.append("<h2>Hosts</h2><p>Each host renders the written asset with its own code and is compared with "
                     "the exact reference of the lighting model it evaluates (half_angle: the paper's light; "
                     "view_angle: uniform white environment, film colour at |N.V|), over feather-tip pixels.</p>"
                     + _head("host", "variant", "lobe", "pixels", "median dE", "p95 dE", "green", "purple",
                             "hue agreement", "passed"))
        for h in report.hosts:
            if h.metrics is None:
                why = f"{'skipped' if h.status == 'skipped' else 'error'}: {h.reason}"
                parts.append(f"<tr><td style='text-align:left'>{e(h.name)}</td>"
                             f"<td colspan='9' style='text-align:left'>{e(why)}</td></tr>")
            else:
                m = h.metrics
                parts.append(_row(h.name, e(str(h.variant)), e(str(h.lobe)), m.n_pixels, _fmt(m.median_dE),
                                  _fmt(m.p95_dE), m.green_px, m.purple_px, _fmt(m.hue_agreement),
                                  "yes" if h.passed else "no"))
        parts.append("</table>")
        parts += [_figure_row(f"{host}: {name}", files, {"host": host, "reference": "reference", "dE": "dE"})
                  for host, per_view in images.hosts.items() for name, files in per_view.items()]
    parts.append("<h2>Renders and dE2000 maps</h2>")
    parts += [_figure_row(name, files, {"gl": "gl", "reference": "reference", "dE": "dE"})
              for name, files in images.views.items()]
    if images.bench:
        parts.append("<h2>Benchmarks</h2>" + "".join(f"<img src='{e(f)}' alt='{e(f)}'>" for f in images.bench))
    parts.append(_pairs("Timings (s)", report.timings_s, _fmt))
    parts.append(_pairs("Library versions", report.versions, lambda v: e(str(v))))
    parts.append("<p>Full data: <a href='report.json'>report.json</a></p></body></html>")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(p for p in parts if p))
    return os.fspath(path)
