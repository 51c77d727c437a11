"""Film models: the refractive index of the iridescent keratin layer and of the media around it.

A :class:`FilmModel` is one film b between an incident medium a and a substrate c (the inputs of
:func:`rockdove.optics.reflectance`), its index a two-term Cauchy law ``n_b(lambda) = A + B / lambda**2 (+ i k)``
(lambda in nm, B in nm**2, an optional constant extinction k). Complex indices are ``n + i k`` with ``k >= 0``
absorbing (fields ~ ``exp(i (k_z z - omega t))``), the convention of ``tmm`` (Byrnes 2016) and of
``colour.phenomena``, so their results compare directly.

References: Leertouwer, H. L., Wilts, B. D. and Stavenga, D. G. (2011), Refractive index and dispersion of
butterfly chitin and bird keratin measured by polarizing interference microscopy, Opt. Express 19(24), 24061:
bird feather keratin n = 1.532 + 5.89e3 / lambda**2 (lambda in nm). The seed paper (real-time structural colour
of the rock dove): constant n = 1.5, air on both sides."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .errors import UsageError

KERATIN_CAUCHY_A = 1.532  # Leertouwer, Wilts & Stavenga 2011, bird feather keratin (lambda in nm)
KERATIN_CAUCHY_B_NM2 = 5.89e3
PAPER_FILM_INDEX = 1.5  # the seed paper's constant keratin index, in air
AIR_INDEX = 1.0


def _check_index(name: str, value) -> complex:
    """One constant refractive index, checked: finite, real part > 0, imaginary part >= 0."""
    try:
        z = complex(value)
    except (TypeError, ValueError):
        raise UsageError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(z.real) and math.isfinite(z.imag)):
        raise UsageError(f"{name} must be finite, got {value!r}")
    if z.real <= 0:
        raise UsageError(f"{name} must have a positive real part, got {value!r}")
    if z.imag < 0:
        raise UsageError(f"{name} must have a non-negative imaginary part (convention n + ik, k >= 0 absorbs), "
                         f"got {value!r}")
    return z


@dataclass(frozen=True)
class FilmModel:
    """One thin film b between an incident medium a and a substrate c (module docstring): ``cauchy_a`` > 0,
    ``cauchy_b_nm2`` >= 0 in nm**2 (0: no dispersion), the constant extinction ``k`` >= 0, a real ``n_incident``
    (reflectance is measured in a transparent medium) and ``n_substrate`` (n + ik); ``name``: the registry's."""

    name: str
    cauchy_a: float
    cauchy_b_nm2: float = 0.0
    k: float = 0.0
    n_incident: complex = AIR_INDEX
    n_substrate: complex = AIR_INDEX

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise UsageError(f"name must be a non-empty string, got {self.name!r}")
        for field, lo_ok in (("cauchy_a", False), ("cauchy_b_nm2", True), ("k", True)):
            value = getattr(self, field)
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise UsageError(f"{field} must be a real number, got {value!r}") from None
            if not math.isfinite(v) or v < 0 or (v == 0 and not lo_ok):
                allowed = ">= 0" if lo_ok else "> 0"
                raise UsageError(f"{field} must be finite and {allowed}, got {value!r}")
            object.__setattr__(self, field, v)
        n_inc = _check_index("n_incident", self.n_incident)
        if n_inc.imag != 0:
            raise UsageError(f"n_incident must be real (a transparent incident medium), got {self.n_incident!r}")
        n_sub = _check_index("n_substrate", self.n_substrate)
        object.__setattr__(self, "n_incident", n_inc.real)
        object.__setattr__(self, "n_substrate", n_sub.real if n_sub.imag == 0 else n_sub)

    @property
    def is_dispersive(self) -> bool:
        """True when the film index depends on wavelength (``cauchy_b_nm2 != 0``)."""
        return self.cauchy_b_nm2 != 0.0

    def n_film(self, wavelength_nm) -> np.ndarray:
        """Film index at ``wavelength_nm`` (> 0), the same shape: float64 if ``k == 0``, else complex128."""
        lam = np.asarray(wavelength_nm, dtype=np.float64)
        if lam.size and not (np.min(lam) > 0 and np.isfinite(np.max(lam))):
            raise UsageError(f"wavelength_nm must be finite and > 0, got values in [{np.min(lam)}, {np.max(lam)}]")
        n = self.cauchy_a + self.cauchy_b_nm2 / (lam * lam)
        return n + 1j * self.k if self.k != 0.0 else n

    def describe(self) -> dict[str, str]:
        """Human-readable description for EXR / USD metadata (all values are strings)."""
        formula = "n(lambda) = A + B / lambda^2 (lambda in nm)" + (" + i k" if self.k else "")
        return {"name": self.name, "formula": formula, "cauchyA": repr(self.cauchy_a),
                "cauchyB_nm2": repr(self.cauchy_b_nm2), "k": repr(self.k),
                "complexIndexConvention": "n + ik, k >= 0 absorbs (as tmm / colour.phenomena)",
                "incidentIndex": repr(self.n_incident), "substrateIndex": repr(self.n_substrate),
                "reference": _REFERENCES.get(self.name, "user-defined film model")}


_REFERENCES = {
    "paper": "seed paper: constant n = 1.5 keratin film in air (real-time rock dove structural colour)",
    "keratin": "Leertouwer, Wilts & Stavenga 2011, Opt. Express 19(24) 24061: bird keratin Cauchy fit",
}

FILMS: dict[str, FilmModel] = {
    "paper": FilmModel("paper", cauchy_a=PAPER_FILM_INDEX),
    "keratin": FilmModel("keratin", cauchy_a=KERATIN_CAUCHY_A, cauchy_b_nm2=KERATIN_CAUCHY_B_NM2),
}


def film_from_config(film_cfg) -> FilmModel:
    """The :class:`FilmModel` of a build configuration's ``[film]`` section (unset coefficients: the model's)."""
    changes = {k: film_cfg[k] for k in ("cauchy_a", "cauchy_b_nm2", "k", "n_incident", "n_substrate")
               if film_cfg.get(k) is not None}
    return replace(get_film(film_cfg["model"]), **changes)


def as_film(film) -> FilmModel:
    """``film`` itself when it is a :class:`FilmModel`, else the registered film of that name (:func:`get_film`)."""
    if isinstance(film, FilmModel):
        return film
    if isinstance(film, str):
        return get_film(film)
    raise UsageError(f"film must be one of {sorted(FILMS)} or a FilmModel, got {film!r}")


def get_film(name: str) -> FilmModel:
    """The registered film model called ``name`` (one of :data:`FILMS`); ValueError otherwise."""
    try:
        return FILMS[name]
    except (KeyError, TypeError):
        raise UsageError(f"film must be one of {sorted(FILMS)}, got {name!r}") from None
