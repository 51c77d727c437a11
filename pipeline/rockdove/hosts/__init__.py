"""Hosts: adapters at the edge that read the WRITTEN asset and render it with their own code (docs/design.md "Hosts").

A host module (registered in :data:`HOSTS`, imported lazily) defines ``NAME``; ``VARIANT``, the network it draws
(``"glsl"``: our paper shaders, ``"baked"``: the MaterialX LUT network, ``"physical"``: the host's own thin-film
BSDF); ``LOBE``, the lighting model of the exact reference it is compared with (one of :data:`LOBES`);
``unavailable() -> str | None`` (None when it can run here, else why not); optionally ``cannot_draw(asset_path)
-> str | None`` (why it cannot draw this asset: the verifier skips it with that reason); and ``render(asset_path,
views, out_dir) -> {view.name: (H, W, 3) float32 linear Rec.709}``, each View's camera exactly, background 0,
raising :class:`HostError` when the host fails. ``rockdove verify --hosts`` reports the hosts :func:`select`
finds unavailable as skips with their reasons, never a silent pass.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import ModuleType, SimpleNamespace

from ..errors import RockdoveError, UsageError

#: host name -> module, or ``module:attribute`` for one of several hosts a module defines (e.g. Storm's three
#: networks); imported only when the host is asked for.
HOSTS = {
    "glsl": "rockdove.hosts.glsl",
    "materialx": "rockdove.hosts.materialx",
    "materialx_physical": "rockdove.hosts.materialx:PHYSICAL",
    "blender": "rockdove.hosts.blender",
    "web": "rockdove.hosts.web",
    "storm": "rockdove.hosts.storm:BAKED",
    "storm_physical": "rockdove.hosts.storm:PHYSICAL",
    "storm_preview": "rockdove.hosts.storm:PREVIEW",
    "osl": "rockdove.hosts.osl:BAKED",
    "osl_physical": "rockdove.hosts.osl:PHYSICAL",
}
#: The hosts a verification runs when none are named: those whose frames cost seconds. Storm's (5-45 s a 512 px
#: frame, mostly shader compilation) and the OSL renderer's are named explicitly or with ``all``.
DEFAULT = ("glsl", "materialx", "materialx_physical", "blender", "web")
#: The lighting models a host can be compared under (docs/design.md "Hosts"):
#: ``half_angle``: the paper's Lambert x colour(cos = L.H) under the View's one directional light;
#: ``view_angle``: the smooth film's mirror lobe alone under a uniform white environment of unit radiance,
#: so a feather-tip pixel is the exact film colour at cos = |N.V| (times the mask), base colour black.
LOBES = ("half_angle", "view_angle")
#: Radiance of the ``view_angle`` lobe's uniform white environment (linear Rec.709, D65 white = 1).
ENVIRONMENT_RADIANCE = 1.0
#: The host every verification runs (our own GLSL shaders).
ALWAYS = "glsl"


class HostError(RockdoveError, RuntimeError):
    """Host ``name`` failed to render (no display, import error, shader compile error...): ``message``, one line."""

    def __init__(self, name: str, message: str):
        super().__init__(f"host {name!r}: {message}")
        self.name = name
        self.message = message


def variant_host(name: str, variant: str, lobe: str, unavailable, render, cannot_draw=None) -> SimpleNamespace:
    """Host ``name`` of a module that draws several networks (``module:attribute`` in :data:`HOSTS`): network
    ``variant`` (``cannot_draw(asset_path, variant)`` says why an asset lacks it), rendered by
    ``render(asset_path, views, out_dir, name=name)``."""
    return SimpleNamespace(NAME=name, VARIANT=variant, LOBE=lobe, unavailable=unavailable,
                           cannot_draw=lambda asset_path: cannot_draw and cannot_draw(asset_path, variant),
                           render=lambda asset_path, views, out_dir: render(asset_path, views, out_dir, name=name))


def load(name: str) -> ModuleType:
    """The module of host ``name``; ValueError for an unknown name, ImportError (:func:`select` turns it into a
    reason) for a module that is absent or fails to import."""
    if name not in HOSTS:
        raise UsageError(f"host {name!r} is unknown; allowed: {', '.join(HOSTS)}")
    module, _, attr = HOSTS[name].partition(":")
    loaded = importlib.import_module(module)
    return getattr(loaded, attr) if attr else loaded


@dataclass(frozen=True)
class Selection:
    """The outcome of :func:`select`: ``available`` host modules in the order asked, and the
    ``unavailable`` ones as ``{name: reason}``."""

    available: tuple
    unavailable: dict


def _reason(name: str) -> tuple[ModuleType | None, str | None]:
    try:
        module = load(name)
    except ImportError as exc:
        gone = isinstance(exc, ModuleNotFoundError) and exc.name and HOSTS[name].startswith(exc.name)
        return None, f"its module {HOSTS[name]} " + ("is not part of this installation" if gone else
                                                     f"cannot be imported: {exc}")
    try:
        reason = module.unavailable()
    except Exception as exc:  # a probe that crashes is a reason, not a crash of verify
        return None, f"{HOSTS[name]}.unavailable() raised {type(exc).__name__}: {exc}"
    return (None, str(reason)) if reason else (module, None)


def select(names=None) -> Selection:
    """The hosts among ``names`` (:data:`HOSTS`, ``["all"]`` for every one; default :data:`DEFAULT`) that can run
    here, :data:`ALWAYS` first, and why the others cannot. ValueError (one line) names an unknown host."""
    names = list(DEFAULT) if names is None else [str(n).strip() for n in names]
    if names == ["all"]:
        names = list(HOSTS)
    unknown = [n for n in names if n not in HOSTS]
    if unknown:
        raise UsageError(f"hosts: {', '.join(map(repr, unknown))} unknown; allowed: {', '.join(HOSTS)}")
    found = {name: _reason(name) for name in dict.fromkeys([ALWAYS, *names])}
    return Selection(tuple(m for m, _ in found.values() if m is not None),
                     {name: why for name, (m, why) in found.items() if m is None})
