"""The real amplitude coefficients of a film's two interfaces, the input of the real Airy form of the
``spectral_fast``, ``fourier`` (:mod:`.bake`) and ``quadrature`` (:mod:`.quadrature`) bakers, so that they depend
on it and not on each other. Reference: Born, M. & Wolf, E., *Principles of Optics*, 7th ed., sec. 7.6.1."""

from __future__ import annotations

import numpy as np

from .. import optics


def interface_coefficients(film, cos_theta, wavelength_nm, *, outer=True):
    """``a_s, b_s, a_p, b_p`` (r_ab and r_bc per polarisation), ``cos_b`` and ``n_b`` of ``film`` at every
    ``cos_theta`` (A,) (in the incident medium) with every ``wavelength_nm`` (L,): float64 (A, L), or pairwise
    (A,) if not ``outer``; None when a coefficient is complex (absorption, total internal reflection)."""
    n_a = film.n_incident
    n_b = np.asarray(film.n_film(wavelength_nm))
    n_c = film.n_substrate
    if np.iscomplexobj(n_b) or isinstance(n_c, complex):
        return None
    cos_a = np.asarray(cos_theta, dtype=np.float64)
    if outer:
        n_b, cos_a = n_b[None, :], cos_a[:, None]
    # total internal reflection at either interface makes the coefficients complex
    if np.any(n_a**2 * (1.0 - cos_a**2) > np.minimum(n_b, n_c) ** 2):
        return None
    cos_b = np.real(optics.snell_cos(n_a, n_b, cos_a))
    cos_c = np.real(optics.snell_cos(n_a, n_c, cos_a))
    shape = np.broadcast_shapes(cos_a.shape, n_b.shape)
    out = {"cos_b": np.broadcast_to(cos_b, shape), "n_b": np.broadcast_to(n_b, shape)}
    for pol in ("s", "p"):
        out[f"a_{pol}"] = np.real(optics.fresnel_r(n_a, n_b, cos_a, cos_b, pol)) + np.zeros_like(cos_b)
        out[f"b_{pol}"] = np.real(optics.fresnel_r(n_b, n_c, cos_b, cos_c, pol)) + np.zeros_like(cos_b)
    return out
