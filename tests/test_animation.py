"""The report's animation of the shimmer (rockdove.render.animation) and the animated WebP writer
(rockdove.render.images.write_webp)."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image, ImageSequence

from rockdove.render.images import write_webp


def _frames(path, fps=None) -> list[np.ndarray]:
    """The frames of an animated WebP that loops forever, each shown 1 / ``fps`` s."""
    with Image.open(path) as im:
        assert im.format == "WEBP" and im.info.get("loop") == 0 and im.is_animated
        frames = [(np.asarray(f.convert("RGB")), f.info["duration"]) for f in ImageSequence.Iterator(im)]
    assert fps is None or {d for _, d in frames} == {round(1000 / fps)}
    return [f for f, _ in frames]


def test_write_webp_keeps_every_frame_in_order_and_rejects_bad_frames(tmp_path):
    colours = [(200, 30, 30), (30, 200, 30), (30, 30, 200)]
    frames = [np.full((24, 32, 3), c, np.uint8) for c in colours]
    path = write_webp(frames, tmp_path / "a.webp", fps=4)
    back = _frames(path, fps=4)
    assert len(back) == 3 and back[0].shape == (24, 32, 3)
    for got, want in zip(back, colours):
        assert np.abs(got.reshape(-1, 3).mean(axis=0) - want).max() < 8
    for bad in ([], [frames[0], frames[1][:10]], [frames[0].astype(np.float32)], [frames[0][..., :2]]):
        with pytest.raises(ValueError, match="frames must be"):
            write_webp(bad, tmp_path / "b.webp", fps=4)
    with pytest.raises(ValueError, match="fps"):
        write_webp(frames, tmp_path / "b.webp", fps=0)
    assert not (tmp_path / "b.webp").exists()


@pytest.mark.gl
def test_the_light_turns_and_the_neck_colour_moves(small_asset, tmp_path):
    """24 frames of the light turning round the bird: the share of green among the green and purple pixels (the
    neck's film: nothing else is green or purple) swings across the turn; with a still light it would not."""
    from rockdove.render.animation import render_light_turn
    from rockdove.render.scene import load_scene
    from rockdove.srgb import srgb_decode
    from rockdove.verify.compare import hue_histogram

    entry = render_light_turn(load_scene(str(small_asset / "pigeon.usda")), tmp_path / "turn.webp", 24, 128)
    frames = _frames(tmp_path / "turn.webp", entry["fps"])
    assert len(frames) == entry["frames"] == 24 and frames[0].shape == (128, 128, 3)
    assert entry["bytes"] == (tmp_path / "turn.webp").stat().st_size and entry["files"] == {"light_turn": "turn.webp"}
    shares, coloured = [], []
    for f in frames:
        h = hue_histogram(srgb_decode(f.reshape(-1, 3) / 255.0))
        coloured.append(h.green + h.purple)
        shares.append(h.green / max(1, h.green + h.purple))
    assert min(coloured[:6]) > 200, coloured  # the neck fills the frame while lit from the camera's side
    lit = [s for s, n in zip(shares, coloured) if n > 100]
    assert max(lit) > 0.4 and min(lit) < 0.2 and max(lit) - min(lit) > 0.3, np.round(shares, 2).tolist()
