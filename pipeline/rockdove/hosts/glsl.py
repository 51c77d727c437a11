"""The ``glsl`` host: the project's paper shaders (``materials/glsl/thinfilm.*``) in pyrender through EGL, compared
with the paper's half-angle model; a LUT-less asset is verified with a LUT baked in memory instead."""

from __future__ import annotations

from .base import Host, HostError, save_pngs


class GLSLHost(Host):
    """Our paper shaders in pyrender (module docstring)."""

    def unavailable(self) -> str | None:
        from .._compat import import_pyrender

        try:
            import_pyrender()
            import OpenGL.GL  # noqa: F401
        except ImportError as exc:
            return f"{'PyOpenGL' if 'OpenGL' in str(exc) else 'pyrender'} is not installed ({exc})"
        return None

    def cannot_draw(self, asset_path: str) -> str | None:
        from ..render.scene import load_scene

        try:
            film = load_scene(asset_path).film
        except ValueError as exc:
            return f"the GLSL shaders cannot draw this asset: {exc}"
        if film is not None and film.lut_file is None:
            return "the GLSL shaders cannot draw this asset without a LUT: it records no rockdove:lut:file"
        return None

    def render(self, asset_path: str, views, out_dir: str | None) -> dict:
        """:meth:`Host.render` with the GLSL shaders; ``<view>_glsl.png`` (sRGB) into ``out_dir`` when given."""
        from ..render.gl import render_views
        from ..render.scene import load_scene

        views = list(views)
        try:
            results = render_views(load_scene(asset_path), views)
        except (ValueError, RuntimeError, OSError) as exc:
            raise HostError(self.name, str(exc)) from None
        images = {r.view.name: r.radiance_rgb for r in results}
        if out_dir:
            save_pngs(images, out_dir, self.name)
        return images


HOST = GLSLHost("glsl", "glsl", "half_angle")
