"""The host contract (as OpenUSD's ``BaseRuleChecker`` defines a rule): a host renders the WRITTEN asset with its own
code, compared with the exact reference of its :data:`Lobe`; one instance per network (docs/design.md, "Hosts")."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, get_args

from ..errors import RockdoveError

if TYPE_CHECKING:
    import numpy as np

    from ..render.views import View

#: The network a host draws: ``glsl`` our paper shaders, ``baked`` the MaterialX LUT network, ``physical`` the
#: host's own thin-film BSDF, ``preview`` the UsdPreviewSurface atlas.
Variant = Literal["glsl", "baked", "physical", "preview"]
#: The lighting models a host can be compared under: ``half_angle``: the paper's Lambert x colour(cos = L.H)
#: under the View's one directional light; ``view_angle``: the smooth film's mirror lobe alone under a uniform
#: white environment of unit radiance, so a feather-tip pixel is the exact film colour at cos = |N.V| (times the
#: mask), base colour black.
Lobe = Literal["half_angle", "view_angle"]
VARIANTS: tuple[Variant, ...] = get_args(Variant)
LOBES: tuple[Lobe, ...] = get_args(Lobe)
#: Radiance of the ``view_angle`` lobe's uniform white environment (linear Rec.709, D65 white = 1).
ENVIRONMENT_RADIANCE = 1.0


class HostError(RockdoveError, RuntimeError):
    """Host ``name`` failed to render (no display, import error, shader compile error...): ``message``, one line."""

    def __init__(self, name: str, message: str):
        super().__init__(f"host {name!r}: {message}")
        self.name = name
        self.message = message


@dataclass(frozen=True)
class Host:
    """A renderer the verification checks; the verification's cache keys its renders on the code of :meth:`render`."""

    name: str
    variant: Variant
    lobe: Lobe

    def __post_init__(self) -> None:
        if self.variant not in VARIANTS or self.lobe not in LOBES:
            raise ValueError(f"host {self.name!r}: variant {self.variant!r} / lobe {self.lobe!r}; allowed: "
                             f"{', '.join(VARIANTS)} / {', '.join(LOBES)}")

    def unavailable(self) -> str | None:
        """None when the host can run here, else why not (a few words: the verifier reports it as a skip)."""
        return None

    def cannot_draw(self, asset_path: str) -> str | None:
        """Why the host cannot draw this asset (e.g. it lacks the network), else None: the verifier skips it."""
        return None

    def render(self, asset_path: str, views: Sequence[View], out_dir: str) -> dict[str, np.ndarray]:
        """``{view.name: (H, W, 3) float32 linear Rec.709 radiance}``, background 0; HostError when it fails."""
        raise NotImplementedError(f"{type(self).__name__}.render")


def save_pngs(images: dict[str, np.ndarray], out_dir: str, host: str) -> None:
    """Each ``{view: linear radiance}`` image as ``out_dir/<view>_<host>.png`` (sRGB), for people."""
    import os

    from ..png import save_png
    from ..srgb import linear_to_srgb8

    os.makedirs(out_dir, exist_ok=True)
    for name, rgb in images.items():
        save_png(linear_to_srgb8(rgb), os.path.join(out_dir, f"{name}_{host}.png"))
