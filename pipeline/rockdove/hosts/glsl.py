"""The ``glsl`` host: the project's own paper shaders (``materials/glsl/thinfilm.*``) drawn by pyrender through
EGL (:mod:`rockdove.render.gl`), compared with the paper's half-angle model.

It draws the LUT the asset names. A LUT-less (physical-only) asset has nothing for these shaders to draw
(:func:`cannot_draw`); ``rockdove verify`` checks such an asset with a LUT baked in memory
(:meth:`rockdove.render.scene.RenderScene.load_lut`) and hands its GL renders to the host check directly.
"""

from __future__ import annotations

import os

from .base import Host, HostError


class GLSLHost(Host):
    """Our paper shaders in pyrender (module docstring)."""

    def unavailable(self) -> str | None:
        """None when pyrender and PyOpenGL import, else why not."""
        from .._compat import import_pyrender

        try:
            import_pyrender()
            import OpenGL.GL  # noqa: F401
        except ImportError as exc:
            return f"{'PyOpenGL' if 'OpenGL' in str(exc) else 'pyrender'} is not installed ({exc})"
        return None

    def cannot_draw(self, asset_path: str) -> str | None:
        """Why the GLSL shaders cannot draw this asset (it has no LUT), else None."""
        from ..render.scene import load_scene

        try:
            film = load_scene(asset_path).film
        except ValueError as exc:
            return f"the GLSL shaders cannot draw this asset: {exc}"
        if film is not None and film.lut_file is None:
            return "the GLSL shaders cannot draw this asset without a LUT: it records no rockdove:lut:file"
        return None

    def render(self, asset_path: str, views, out_dir: str | None) -> dict:
        """Render ``views`` of the written asset with the GLSL shaders (:class:`~rockdove.hosts.base.Host`);
        ``<view>_glsl.png`` (sRGB) into ``out_dir`` when given."""
        from ..render.gl import render_views
        from ..render.scene import load_scene

        views = list(views)
        try:
            results = render_views(load_scene(asset_path), views)
        except (ValueError, RuntimeError, OSError) as exc:
            raise HostError(self.name, str(exc)) from None
        images = {r.view.name: r.radiance_rgb for r in results}
        if out_dir:
            from ..png import save_png
            from ..srgb import linear_to_srgb8

            os.makedirs(out_dir, exist_ok=True)
            for name, rgb in images.items():
                save_png(linear_to_srgb8(rgb), os.path.join(out_dir, f"{name}_{self.name}.png"))
        return images


HOST = GLSLHost("glsl", "glsl", "half_angle")
