"""The verification report's images (rockdove.verify.report): the dE2000 map drawn pixel for pixel with its colour
bar and title, the colormap lookup, and the matplotlib charts' fixed margins holding their labels."""

import numpy as np
import pytest
from matplotlib import colormaps
from PIL import Image

from rockdove.films import get_film
from rockdove.render.film import ThinFilmParams
from rockdove.verify import report
from rockdove.verify.compare import HueHistogram


def _cmap8(x):
    """The colormap's colour of x in [0, 1], rounded to uint8 (the oracle: matplotlib's own call)."""
    return (np.asarray(colormaps[report.DE_COLORMAP](x))[..., :3] * 255).round().astype(np.uint8)


def test_de_colour_is_the_colormap_of_de_over_vmax_with_nan_grey():
    de = np.array([[0.0, 1e-9, 0.5, 2.5], [4.99, 5.0, 7.0, -1.0], [np.nan, np.inf, 2.0 + 1e-12, 3.3]])
    out = report.de_colour(de)
    assert out.dtype == np.uint8 and out.shape == (3, 4, 3)
    finite = np.isfinite(de)
    np.testing.assert_array_equal(out[finite], _cmap8(np.clip(de[finite] / report.DE_MAP_MAX, 0.0, 1.0)))
    assert (out[~finite] == 96).all()


@pytest.fixture(scope="module", params=[40, 100])
def de_png(request, tmp_path_factory):
    """An H x 60 dE map: a ramp over 0-7 with a not-compared corner; its top-left value (2.5) is unique."""
    de = np.tile(np.linspace(0.0, 7.0, 60), (request.param, 1))
    de[request.param // 2:, 40:] = np.nan
    de[0, 0] = 2.5
    path = report.de_map_png(tmp_path_factory.mktemp("de") / "m_dE.png", de, "view: dE2000 median 1.00")
    with Image.open(path) as im:
        assert im.mode == "RGB"
        return de, np.asarray(im)


def _map_origin(px, colours):
    """(y, x) where ``colours`` stands in ``px`` exactly, or None."""
    h, w = colours.shape[:2]
    for y, x in np.argwhere((px == colours[0, 0]).all(-1)):
        if (px[y:y + h, x:x + w].shape[:2] == (h, w)) and np.array_equal(px[y:y + h, x:x + w], colours):
            return int(y), int(x)
    return None


def test_de_map_png_shows_every_de_pixel_through_the_colormap_unresampled(de_png):
    de, px = de_png
    assert _map_origin(px, report.de_colour(de)) is not None


def test_de_map_png_has_a_colour_bar_from_the_colormap_top_to_bottom_and_a_title(de_png, tmp_path):
    de, px = de_png
    y, x = _map_origin(px, report.de_colour(de))
    h, w = de.shape
    ramp = report.de_colour(np.linspace(report.DE_MAP_MAX, 0.0, h)[:, None])[:, 0]
    bar = [c for c in range(x + w, px.shape[1]) if np.array_equal(px[y:y + h, c], ramp)]
    assert len(bar) >= 4  # a strip, beside the map
    np.testing.assert_array_equal(px[y, bar[0]], _cmap8(1.0))
    np.testing.assert_array_equal(px[y + h - 1, bar[0]], _cmap8(0.0))
    # right of the bar, below the title, three runs of dark columns: the frame with a tick mark at each whole
    # dE (only at 0 and the top on a map too short for six labels), the tick labels (one beside each tick), the
    # bar's name (written along the bar); the title above the map
    dark = (px < 128).all(-1)
    values = np.arange(0.0, report.DE_MAP_MAX + 1.0) if h > 50 else np.array([0.0, report.DE_MAP_MAX])
    ticks = y + np.round((1.0 - values / report.DE_MAP_MAX) * (h - 1)).astype(int)
    assert dark[ticks, bar[-1] + 2].all()
    assert dark[y + 1:y + h - 1, bar[-1] + 2].sum() == len(ticks) - 2  # no others
    cols = np.flatnonzero(dark[y:, bar[-1] + 1:].any(0)) + bar[-1] + 1
    runs = np.split(cols, np.flatnonzero(np.diff(cols) > 1) + 1)
    assert len(runs) == 3
    assert all(dark[t - 4:t + 5, runs[1]].any() for t in ticks)
    rows = np.flatnonzero(dark[y:, runs[2]].any(1))
    assert rows[-1] - rows[0] > h / 2
    assert dark[:y - 1, x:x + w].sum() > 20
    # without a title the header holds nothing dark: the count above measured the title
    de_map = report.de_map_png(tmp_path / "untitled.png", de, "")
    with Image.open(de_map) as im:
        assert not (np.asarray(im)[:y - 1, x:x + w] < 128).all(-1).any()


def _white_border(path, px=2):
    with Image.open(path) as im:
        a = np.asarray(im.convert("RGB"))
    edges = np.concatenate([a[:px].reshape(-1, 3), a[-px:].reshape(-1, 3), a[:, :px].reshape(-1, 3),
                            a[:, -px:].reshape(-1, 3)])
    return a, (edges == 255).all()


def test_charts_fit_their_labels_in_their_fixed_margins(tmp_path):
    film = ThinFilmParams(model=get_film("keratin"))
    a, white = _white_border(report.spectra_png(tmp_path / "s.png", film, thickness_nm=(500.0, 650.0)))
    assert a.shape == (520, 700, 3) and white
    tab10 = [np.round(np.asarray(colormaps["tab10"](i)[:3]) * 255) for i in range(4)]
    assert all((np.abs(a.astype(int) - c).sum(-1) < 20).sum() > 100 for c in tab10)  # the four angles' lines
    edges = np.linspace(0.0, 360.0, 13)
    hue = HueHistogram(list(edges), [999999 // (i + 1) for i in range(12)], grey=3, green=1, purple=2, other=4,
                       min_saturation=0.15, green_band_deg=[100.0, 210.0], purple_band_deg=[280.0, 15.0])
    a, white = _white_border(report.hue_png(tmp_path / "h.png", hue, "light sweep"))  # 6-digit tick labels
    assert a.shape == (300, 600, 3) and white


def test_library_versions_are_read_once_and_each_call_gets_its_own_dict(monkeypatch):
    from importlib import metadata

    from rockdove.verify import provenance

    provenance._library_versions.cache_clear()
    first = provenance.library_versions()
    assert first["numpy"] == metadata.version("numpy") and first["PIL"] == metadata.version("pillow")
    first["numpy"] = "edited by a caller"

    def no_second_read(name):
        raise AssertionError(f"metadata read again for {name}")

    monkeypatch.setattr(metadata, "version", no_second_read)
    again = provenance.library_versions()
    assert again["numpy"] == np.__version__ and again is not first
