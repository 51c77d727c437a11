"""The thin-film colour table: structural colour over (cos theta, film thickness), and its lookup.

Layout (the contract between the baker, the EXR file, the GLSL/MaterialX shaders and the verifier)
---------------------------------------------------------------------------------------------------
``rgb[i, j]`` is the colour at thickness node ``i`` and angle node ``j``; shape ``(n_thickness, n_angle, 3)``,
float32, linear, in the working colour space ``colour_space`` (default ``lin_rec709``), unclipped: thin-film
colours can lie outside the gamut, so components may be negative.

Angle axis. Nodes are uniform in a warped coordinate ``x = cos_theta ** (1 / angle_warp_gamma)``:
``x_j = j / (n_angle - 1)``, so ``cos_theta_j = x_j ** angle_warp_gamma``. ``gamma = 1`` is uniform in
cos theta; ``gamma > 1`` puts more nodes near grazing incidence (cos theta -> 0), where colour changes fastest.
cos theta is the cosine of the angle of incidence on the film, in the incident medium.

Thickness axis. Nodes are uniform in nm over ``thickness_range_nm = (lo, hi)``:
``d_i = lo + (hi - lo) * i / (n_thickness - 1)``; a one-texel-high table (``lo == hi``) is the paper's 1-D texture.

Texture coordinates. Texel centres of an N-texel axis sit at ``(k + 0.5) / N``; a node coordinate
``x in [0, 1]`` maps to ``u = (x * (N - 1) + 0.5) / N``. With linear filtering and clamp-to-edge wrapping this
makes a GPU lookup exactly the piecewise-linear interpolation between nodes that :meth:`ThinFilmLUT.sample`
computes, **as long as the texture is not minified**: hosts that mipmap image nodes (MaterialX renderers,
Storm) pick a mip level from the screen derivative of the angle coordinate and average ``2**level`` texels
along *both* axes, so the thickness rows mix as well. Measured with MaterialX's generated GLSL (LUT
mipmapped, trilinear): on the default bird at 512 x 512 the cost is median dE2000 0.017, p95 0.05; on a
sphere of constant thickness at 256 x 256 (the worst case: the angle changes fast over the whole disc) the
default 256 x 64 layout errs median 0.8-1.0, p95 10-13, and a tall 64 x 256 layout (same texel count and bake
time; `lut.angles = 64`, `lut.thicknesses = 256`; its own error vs the exact film max 0.27 instead of 0.05)
errs median 0.01-0.02, p95 0.35-0.54, max 1.9 (``pipeline/rockdove/hosts/materialx.py``, ``docs/design.md``).
In the EXR file and in USD the bottom image row is ``i = 0`` (USD's ``st`` has t = 0 at the bottom);
uploaded to OpenGL, row 0 of ``rgb`` is t = 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class ThinFilmLUT:
    """Baked structural colour over (cos theta, thickness).

    Attributes
    ----------
    rgb : ndarray, shape (n_thickness, n_angle, 3), float32
        Linear colour in ``colour_space``; read-only.
    thickness_range_nm : (float, float)
        ``(lo, hi)`` of the thickness axis, nm; ``lo == hi`` for a one-texel-high table.
    angle_warp_gamma : float
        ``cos_theta = x ** angle_warp_gamma`` with ``x`` uniform in [0, 1] over the angle nodes.
    colour_space : str
        MaterialX colour-space name of ``rgb`` (``lin_rec709`` or ``acescg``).
    metadata : dict[str, str]
        Provenance written into the EXR header: film model, illuminant, observer, method, error estimate...
    """

    rgb: np.ndarray
    thickness_range_nm: tuple[float, float]
    angle_warp_gamma: float = 1.0
    colour_space: str = "lin_rec709"
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        rgb = np.asarray(self.rgb, dtype=np.float32)
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.shape[1] < 2 or rgb.shape[0] < 1:
            raise ValueError(f"rgb must have shape (n_thickness >= 1, n_angle >= 2, 3), got {rgb.shape}")
        if not np.all(np.isfinite(rgb)):
            raise ValueError("rgb must be finite")
        lo, hi = (float(v) for v in self.thickness_range_nm)
        if not (np.isfinite(lo) and np.isfinite(hi)) or lo < 0 or hi < lo:
            raise ValueError(f"thickness_range_nm must be (lo, hi) with 0 <= lo <= hi, got {(lo, hi)}")
        if (rgb.shape[0] == 1) != (lo == hi):
            raise ValueError(
                f"a one-texel-high table needs lo == hi and vice versa; got {rgb.shape[0]} rows for {(lo, hi)}"
            )
        if not (np.isfinite(self.angle_warp_gamma) and self.angle_warp_gamma > 0):
            raise ValueError(f"angle_warp_gamma must be > 0, got {self.angle_warp_gamma}")
        object.__setattr__(self, "rgb", _readonly(rgb))
        object.__setattr__(self, "thickness_range_nm", (lo, hi))
        object.__setattr__(self, "angle_warp_gamma", float(self.angle_warp_gamma))
        object.__setattr__(self, "metadata", dict(self.metadata))

    # -- axes -------------------------------------------------------------------------------------
    @property
    def n_angle(self) -> int:
        return self.rgb.shape[1]

    @property
    def n_thickness(self) -> int:
        return self.rgb.shape[0]

    @property
    def cos_theta(self) -> np.ndarray:
        """Angle nodes, cos theta, shape (n_angle,), increasing from 0 to 1."""
        x = np.linspace(0.0, 1.0, self.n_angle)
        return x**self.angle_warp_gamma

    @property
    def thickness_nm(self) -> np.ndarray:
        """Thickness nodes in nm, shape (n_thickness,)."""
        lo, hi = self.thickness_range_nm
        return np.linspace(lo, hi, self.n_thickness) if self.n_thickness > 1 else np.array([lo])

    # -- lookup -----------------------------------------------------------------------------------
    def node_coords(self, cos_theta, thickness_nm):
        """Fractional node coordinates in [0, 1] along each axis (clamped), before the texel-centre offset.

        Returns ``(x, y)``: ``x = clamp(cos_theta, 0, 1) ** (1 / gamma)``, ``y = clamp((d - lo) / (hi - lo))``
        (0 for a one-texel-high table).
        """
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
        """Bilinear lookup, clamped at the edges: the same result as a GPU's linear filtering.

        Parameters
        ----------
        cos_theta : array_like
            Cosine of the angle of incidence, broadcastable with ``thickness_nm``; clamped to [0, 1].
        thickness_nm : array_like
            Film thickness in nm; clamped to ``thickness_range_nm``.

        Returns
        -------
        ndarray, shape broadcast(cos_theta, thickness_nm) + (3,), float64
        """
        x, y = self.node_coords(cos_theta, thickness_nm)
        fx = x * (self.n_angle - 1)
        fy = y * (self.n_thickness - 1)
        j0 = np.clip(np.floor(fx).astype(np.intp), 0, self.n_angle - 2)
        i0 = np.clip(np.floor(fy).astype(np.intp), 0, max(self.n_thickness - 2, 0))
        i1 = np.minimum(i0 + 1, self.n_thickness - 1)
        tx = (fx - j0)[..., None]
        ty = (fy - i0)[..., None]
        t = self.rgb  # float32 texels gathered, then promoted exactly by the float64 weights (no full-table copy)
        c0 = t[i0, j0] * (1 - tx) + t[i0, j0 + 1] * tx
        c1 = t[i1, j0] * (1 - tx) + t[i1, j0 + 1] * tx
        return c0 * (1 - ty) + c1 * ty
