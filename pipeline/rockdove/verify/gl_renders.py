"""The verification's GL renders in a thread of this process, one result per view, drawn while this thread
integrates the CPU reference and compares the views already drawn: llvmpipe draws and reads back outside the GIL,
numpy's reference mostly too. A thread, not a process: measured (docs/design.md, "The GL renders"), a worker
process saved nothing once the imports are warm. pyrender is imported by the first render (importing it ahead in
a thread while the build imported pxr deadlocked a CLI build). All GL calls of one :class:`GLRenders` run on its
own single thread (an EGL context is current on one thread)."""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from ..errors import RockdoveError


class GLRenderError(RockdoveError, RuntimeError):
    """The GL renderer could not open, or a view failed to render; the message says why."""


class GLRenders:
    """The GL renders of ``views`` (one :class:`rockdove.render.gl.GLRenderer` opened at the first view's size,
    as :func:`rockdove.render.gl.render_views` does, so the images are the same); :meth:`result` waits for one."""

    def __init__(self, scene, views, lut=None):
        views = list(views)
        pool = ThreadPoolExecutor(1, thread_name_prefix="rockdove-gl")
        renderer: Any = None

        def open_() -> float:
            nonlocal renderer
            t = time.perf_counter()
            from ..render.gl import GLRenderer

            renderer = GLRenderer(scene, lut=lut, width=views[0].width, height=views[0].height)
            return time.perf_counter() - t

        def render(view):  # after a failed open: result() raises the open's error first
            t = time.perf_counter()
            return renderer.render(view), time.perf_counter() - t

        def close() -> None:
            if renderer is not None:
                renderer.delete()

        self._open = pool.submit(open_)
        self._views = [pool.submit(render, v) for v in views]
        pool.submit(close)
        pool.shutdown(wait=False)

    def result(self, i: int):
        """View ``i``'s ``(RenderResult, seconds)``, the seconds with its share of opening the renderer;
        :class:`GLRenderError` naming the renderer's error when it could not open or the view failed."""
        try:
            open_s = self._open.result()
        except Exception as exc:
            raise GLRenderError(f"the GL renderer could not open: {type(exc).__name__}: {exc}") from exc
        try:
            image, seconds = self._views[i].result()
        except Exception as exc:
            raise GLRenderError(f"{type(exc).__name__}: {exc}") from exc
        return image, seconds + open_s / len(self._views)
