"""Hosts: adapters at the edge that read the WRITTEN asset and render it with their own code (docs/hosts.md), in
:data:`HOSTS`. ``rockdove verify --hosts`` reports the unavailable ones as skips with their reasons, never a pass."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import UsageError
from . import blender, glsl, materialx, osl, storm, web
from .base import ENVIRONMENT_RADIANCE, LOBES, VARIANTS, Host, HostError, Lobe, Variant

__all__ = ["ALWAYS", "DEFAULT", "ENVIRONMENT_RADIANCE", "HOSTS", "LOBES", "VARIANTS", "Host", "HostError", "Lobe",
           "Selection", "Variant", "register", "select"]

#: host name -> :class:`Host`, in the order ``all`` runs them.
HOSTS: dict[str, Host] = {}
#: The hosts a verification runs when none are named: those whose frames cost seconds. Storm's (5-45 s a 512 px
#: frame, mostly shader compilation) and the OSL renderer's are named explicitly or with ``all``.
DEFAULT = ("glsl", "materialx", "materialx_physical", "blender", "web")
#: The host every verification runs (our own GLSL shaders).
ALWAYS = "glsl"


def register(host: Host) -> Host:
    """Add ``host`` to :data:`HOSTS` under its name (a name already taken by another host: UsageError)."""
    if not isinstance(host, Host):
        raise UsageError(f"a host must be a rockdove.hosts.Host, got {type(host).__name__}")
    if HOSTS.get(host.name, host) is not host:
        raise UsageError(f"host name {host.name!r} is taken by {HOSTS[host.name]!r}")
    HOSTS[host.name] = host
    return host


for _host in (glsl.HOST, materialx.BAKED, materialx.PHYSICAL, blender.HOST, web.HOST, *storm.HOSTS, *osl.HOSTS):
    register(_host)


@dataclass(frozen=True)
class Selection:
    """The ``available`` hosts in the order asked, and the ``unavailable`` ones as ``{name: reason}``."""

    available: tuple[Host, ...]
    unavailable: dict[str, str]


def _reason(host: Host) -> str | None:
    try:
        reason = host.unavailable()
    except Exception as exc:  # a probe that crashes is a reason, not a crash of verify
        return f"host {host.name}: unavailable() raised {type(exc).__name__}: {exc}"
    return str(reason) if reason else None


def select(names=None) -> Selection:
    """The hosts among ``names`` (default :data:`DEFAULT`) that can run here, :data:`ALWAYS` first, and why not."""
    names = list(DEFAULT) if names is None else [str(n).strip() for n in names]
    if names == ["all"]:
        names = list(HOSTS)
    if unknown := [n for n in names if n not in HOSTS]:
        raise UsageError(f"hosts: {', '.join(map(repr, unknown))} unknown; allowed: {', '.join(HOSTS)}")
    found = {name: _reason(HOSTS[name]) for name in dict.fromkeys([ALWAYS, *names])}
    return Selection(tuple(HOSTS[n] for n, why in found.items() if why is None),
                     {n: why for n, why in found.items() if why is not None})
