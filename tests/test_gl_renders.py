"""The verification's GL renders in a thread (rockdove.verify.gl_renders): the images equal the ones made on
this thread, in any order of sizes, and a renderer that cannot open fails every view with its error."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from rockdove.verify.gl_renders import GLRenderError, GLRenders


def test_gl_renders_in_their_thread_equal_the_ones_made_here(small_asset):
    from rockdove.render.gl import render_views
    from rockdove.verify.inputs import verification_scene, verification_views

    layer, scene, lut, _ = verification_scene(small_asset)
    every = verification_views(scene, 48, 32, 3)
    views = [every[0], every[-1]]  # a turntable frame and the hero (twice the size)
    assert views[1].width == 2 * views[0].width
    here = render_views(scene, views, lut=lut)
    renders = GLRenders(scene, views[::-1], lut)  # the other order, opened at the hero's size
    there = [renders.result(i) for i in range(len(views))][::-1]
    assert all(seconds > 0 for _, seconds in there)
    for a, (b, _) in zip(here, there):
        assert a.view == b.view and a.part_names == b.part_names
        for name in ("radiance_rgb", "alpha", "part_id", "depth_m", "cos_theta", "thickness_nm", "mask", "st"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for t in [t for t in threading.enumerate() if t.name.startswith("rockdove-gl_")]:
        t.join(timeout=30)  # the renderer closed after the last view and its thread ended
        assert not t.is_alive()


def test_gl_renders_that_cannot_open_fail_every_view_with_the_opening_error():
    from rockdove.render.views import View

    view = View(name="v", camera_to_world=np.eye(4), yfov_rad=0.6, width=16, height=16,
                light_direction=np.array([0.0, 0.0, 1.0]), light_rgb=np.ones(3))
    renders = GLRenders("not a scene", [view, view], None)
    for i in range(2):
        with pytest.raises(GLRenderError, match=r"could not open: .*scene must be a RenderScene"):
            renders.result(i)
