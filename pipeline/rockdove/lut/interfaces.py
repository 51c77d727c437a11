"""The real amplitude coefficients of a film's two interfaces, the input of the real-arithmetic Airy form shared
by the ``spectral_fast`` and ``fourier`` bakers (:mod:`.bake`) and by ``quadrature`` (:mod:`.quadrature`).

Its own module so that both bakers depend on it and not on each other. Reference: Born, M. & Wolf, E.,
*Principles of Optics*, 7th ed., sec. 7.6.1 (Airy formula with Fresnel coefficients r_ab, r_bc).
"""

from __future__ import annotations

import numpy as np

from .. import optics


def interface_coefficients(film, cos_theta, wavelength_nm, *, outer=True):
    """Real amplitude coefficients of both interfaces, s and p, and the film's cos theta_b and index.

    Parameters
    ----------
    film : FilmModel
    cos_theta : ndarray, shape (A,)
        Incidence in the incident medium.
    wavelength_nm : ndarray, shape (L,)
    outer : bool
        True: every angle with every wavelength, shape (A, L). False: pairwise (``A == L``), shape (A,).

    Returns
    -------
    dict with ``a_s, b_s, a_p, b_p, cos_b, n_b``, each shape (A, L) (or (A,)) float64, or None when a coefficient
    is complex (absorbing film or substrate, total internal reflection): then only the general path applies.
    """
    n_a = film.n_incident
    n_b = np.asarray(film.n_film(wavelength_nm))
    n_c = film.n_substrate
    if np.iscomplexobj(n_b) or isinstance(n_c, complex):
        return None
    cos_a = np.asarray(cos_theta, dtype=np.float64)
    if outer:
        n_b, cos_a = n_b[None, :], cos_a[:, None]
    # total internal reflection at either interface makes the coefficients complex
    sin2_a = 1.0 - cos_a**2
    if np.any(n_a**2 * sin2_a > np.minimum(n_b, n_c) ** 2):
        return None
    cos_b = np.real(optics.snell_cos(n_a, n_b, cos_a))
    cos_c = np.real(optics.snell_cos(n_a, n_c, cos_a))
    shape = np.broadcast_shapes(cos_a.shape, n_b.shape)
    out = {"cos_b": np.broadcast_to(cos_b, shape), "n_b": np.broadcast_to(n_b, shape)}
    for pol in ("s", "p"):
        out[f"a_{pol}"] = np.real(optics.fresnel_r(n_a, n_b, cos_a, cos_b, pol)) + np.zeros_like(cos_b)
        out[f"b_{pol}"] = np.real(optics.fresnel_r(n_b, n_c, cos_b, cos_c, pol)) + np.zeros_like(cos_b)
    return out
