"""The thin-film colour table: structural colour over (cos theta, film thickness), and its lookup.

Layout (the contract between the baker, the EXR file, the GLSL/MaterialX shaders and the verifier):
``rgb[i, j]`` is the colour at thickness node ``i`` and angle node ``j``, shape ``(n_thickness, n_angle, 3)``,
float32, linear, in ``colour_space`` (default ``lin_rec709``), unclipped (thin-film colours lie outside the gamut).

Angle nodes are uniform in ``x = cos_theta ** (1 / angle_warp_gamma)``: ``cos_theta_j = (j / (n_angle - 1)) **
gamma`` (``gamma > 1`` puts nodes near grazing, where colour changes fastest), cos theta of the angle of
incidence on the film in the incident medium. Thickness nodes are uniform in nm over ``thickness_range_nm = (lo,
hi)``; a one-texel-high table (``lo == hi``) is the paper's 1-D texture.

Texture coordinates: texel centres of an N-texel axis sit at ``(k + 0.5) / N``, so a node coordinate ``x in [0, 1]``
maps to ``u = (x * (N - 1) + 0.5) / N``, and a GPU's linear filtering with clamp-to-edge is the piecewise-linear
interpolation of :meth:`ThinFilmLUT.sample`, **as long as the texture is not minified**: hosts that mipmap image nodes
(MaterialX renderers, Storm) average ``2**level`` texels along both axes, mixing the thickness rows too (measured:
median dE2000 0.017 on the default bird at 512 px; on a sphere of constant thickness the default 256 x 64 errs median
0.8-1.0 where a tall 64 x 256 errs 0.01-0.02; ``docs/design.md``). In the EXR file and in USD the bottom image row is
``i = 0`` (USD's ``st`` has t = 0 at the bottom); uploaded to OpenGL, row 0 of ``rgb`` is t = 0."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UsageError


@dataclass(frozen=True, eq=False)
class ThinFilmLUT:
    """Baked structural colour over (cos theta, thickness) (module docstring): ``rgb`` read-only float32, the
    axes' ``thickness_range_nm`` and ``angle_warp_gamma``, the MaterialX ``colour_space`` name, and the
    provenance ``metadata`` (str -> str) written into the EXR header."""

    rgb: np.ndarray
    thickness_range_nm: tuple[float, float]
    angle_warp_gamma: float = 1.0
    colour_space: str = "lin_rec709"
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        rgb = np.asarray(self.rgb, dtype=np.float32)
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.shape[1] < 2 or rgb.shape[0] < 1:
            raise UsageError(f"rgb must have shape (n_thickness >= 1, n_angle >= 2, 3), got {rgb.shape}")
        if not np.all(np.isfinite(rgb)):
            raise UsageError("rgb must be finite")
        lo, hi = (float(v) for v in self.thickness_range_nm)
        if not (np.isfinite(lo) and np.isfinite(hi)) or lo < 0 or hi < lo:
            raise UsageError(f"thickness_range_nm must be (lo, hi) with 0 <= lo <= hi, got {(lo, hi)}")
        if (rgb.shape[0] == 1) != (lo == hi):
            raise UsageError(f"a one-texel-high table needs lo == hi and vice versa; got {rgb.shape[0]} rows for "
                             f"{(lo, hi)}")
        if not (np.isfinite(self.angle_warp_gamma) and self.angle_warp_gamma > 0):
            raise UsageError(f"angle_warp_gamma must be > 0, got {self.angle_warp_gamma}")
        rgb = np.ascontiguousarray(rgb)
        rgb.setflags(write=False)
        for name, value in (("rgb", rgb), ("thickness_range_nm", (lo, hi)),
                            ("angle_warp_gamma", float(self.angle_warp_gamma)), ("metadata", dict(self.metadata))):
            object.__setattr__(self, name, value)

    @property
    def n_angle(self) -> int:
        return self.rgb.shape[1]

    @property
    def n_thickness(self) -> int:
        return self.rgb.shape[0]

    @property
    def cos_theta(self) -> np.ndarray:
        """Angle nodes, cos theta, shape (n_angle,), increasing from 0 to 1."""
        return np.linspace(0.0, 1.0, self.n_angle) ** self.angle_warp_gamma

    @property
    def thickness_nm(self) -> np.ndarray:
        """Thickness nodes in nm, shape (n_thickness,)."""
        lo, hi = self.thickness_range_nm
        return np.linspace(lo, hi, self.n_thickness) if self.n_thickness > 1 else np.array([lo])

    def node_coords(self, cos_theta, thickness_nm):
        """Node coordinates ``(x, y)`` in [0, 1] before the texel-centre offset: ``x = clamp(cos_theta, 0, 1) ** (1 /
        gamma)``, ``y = clamp((d - lo) / (hi - lo))`` (0 for a one-texel-high table)."""
        c = np.clip(np.asarray(cos_theta, dtype=np.float64), 0.0, 1.0)
        x = c ** (1.0 / self.angle_warp_gamma)
        d = np.asarray(thickness_nm, dtype=np.float64)
        lo, hi = self.thickness_range_nm
        y = np.clip((d - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.zeros_like(d)
        return np.broadcast_arrays(x, y)

    def texcoords(self, cos_theta, thickness_nm):
        """Texture coordinates ``(u, v)`` a shader uses for this lookup (texel-centre convention above)."""
        x, y = self.node_coords(cos_theta, thickness_nm)
        n, m = self.n_angle, self.n_thickness
        return (x * (n - 1) + 0.5) / n, (y * (m - 1) + 0.5) / m

    def sample(self, cos_theta, thickness_nm) -> np.ndarray:
        """Bilinear lookup (float64, broadcast shape + (3,)), clamped to the axes: a GPU's linear filtering."""
        x, y = self.node_coords(cos_theta, thickness_nm)
        fx, fy = x * (self.n_angle - 1), y * (self.n_thickness - 1)
        j0 = np.clip(np.floor(fx).astype(np.intp), 0, self.n_angle - 2)
        i0 = np.clip(np.floor(fy).astype(np.intp), 0, max(self.n_thickness - 2, 0))
        i1 = np.minimum(i0 + 1, self.n_thickness - 1)
        tx, ty = (fx - j0)[..., None], (fy - i0)[..., None]
        t = self.rgb  # float32 texels gathered, then promoted exactly by the float64 weights (no full-table copy)
        c0 = t[i0, j0] * (1 - tx) + t[i0, j0 + 1] * tx
        c1 = t[i1, j0] * (1 - tx) + t[i1, j0 + 1] * tx
        return c0 * (1 - ty) + c1 * ty

    def save(self, folder: Path) -> None:
        """The table as ``rgb.npy`` and ``lut.json`` (axes, colour space, metadata) in ``folder`` (a cache entry)."""
        np.save(folder / "rgb.npy", np.ascontiguousarray(self.rgb, dtype=np.float32))
        (folder / "lut.json").write_text(json.dumps({
            "thickness_range_nm": list(self.thickness_range_nm), "angle_warp_gamma": self.angle_warp_gamma,
            "colour_space": self.colour_space, "metadata": {k: str(v) for k, v in self.metadata.items()}},
            sort_keys=True))

    @classmethod
    def load(cls, folder: Path) -> ThinFilmLUT:
        """The table :meth:`save` wrote into ``folder``."""
        meta = json.loads((folder / "lut.json").read_text())
        return cls(np.load(folder / "rgb.npy"), tuple(meta["thickness_range_nm"]),
                   angle_warp_gamma=meta["angle_warp_gamma"], colour_space=meta["colour_space"],
                   metadata=meta["metadata"])
