"""Film models: the registry, the Cauchy law against the published keratin values, validation."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

import rockdove.films
from rockdove import optics
from rockdove.films import FILMS, FilmModel, get_film


def test_registry_holds_the_paper_and_keratin_films_and_no_default_of_its_own():
    assert set(FILMS) == {"paper", "keratin"}
    assert get_film("keratin") is FILMS["keratin"]
    # the default film is the configuration schema's film.model, written nowhere else
    assert inspect.signature(get_film).parameters["name"].default is inspect.Parameter.empty
    assert not hasattr(rockdove.films, "DEFAULT_FILM")


def test_paper_film_is_a_constant_1_5_in_air():
    paper = get_film("paper")
    n = paper.n_film(np.array([360.0, 550.0, 780.0]))
    np.testing.assert_array_equal(n, 1.5)
    assert n.dtype == np.float64
    assert not paper.is_dispersive
    assert paper.n_incident == 1.0 and paper.n_substrate == 1.0


def test_keratin_cauchy_law_matches_leertouwer_2011_values():
    """method.md: n = 1.569 / 1.556 / 1.548 at 400 / 500 / 600 nm (rounded to 3 decimals)."""
    keratin = get_film("keratin")
    np.testing.assert_allclose(keratin.n_film([400.0, 500.0, 600.0]), [1.569, 1.556, 1.548], atol=5e-4)
    assert keratin.is_dispersive
    lam = np.linspace(360, 780, 50)
    assert np.all(np.diff(keratin.n_film(lam)) < 0)  # normal dispersion


def test_extinction_gives_a_complex_index_in_the_n_plus_ik_convention():
    film = FilmModel("lossy", cauchy_a=1.5, k=0.1)
    n = film.n_film(550.0)
    assert n == 1.5 + 0.1j
    # an absorbing film transmits less than R + T = 1
    r = optics.reflectance(550.0, 0.8, 650.0, n_film=film.n_film)
    t = optics.transmittance(550.0, 0.8, 650.0, n_film=film.n_film)
    assert r + t < 0.99


def test_n_film_is_a_valid_callable_index_for_optics():
    keratin = get_film("keratin")
    lam = np.linspace(400, 700, 7)
    np.testing.assert_array_equal(optics.reflectance(lam, 0.7, 600.0, n_film=keratin.n_film),
                                  optics.reflectance(lam, 0.7, 600.0, n_film=keratin.n_film(lam)))


def test_describe_gives_strings_for_metadata_with_formula_units_and_reference():
    for film in FILMS.values():
        info = film.describe()
        assert all(isinstance(k, str) and isinstance(v, str) for k, v in info.items())
        assert info["name"] == film.name
        assert "lambda in nm" in info["formula"]
        assert float(info["cauchyA"]) == film.cauchy_a and float(info["cauchyB_nm2"]) == film.cauchy_b_nm2
    assert "Leertouwer" in FILMS["keratin"].describe()["reference"]


def test_film_models_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        FILMS["paper"].cauchy_a = 2.0


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(name=""), "name"),
        (dict(cauchy_a=0.0), "cauchy_a"),
        (dict(cauchy_a=-1.5), "cauchy_a"),
        (dict(cauchy_a=float("nan")), "cauchy_a"),
        (dict(cauchy_b_nm2=-1.0), "cauchy_b_nm2"),
        (dict(k=-0.1), "k"),
        (dict(k="x"), "k"),
        (dict(n_incident=1.0 + 0.1j), "n_incident"),
        (dict(n_incident=0.0), "n_incident"),
        (dict(n_substrate=1.5 - 0.2j), "n_substrate"),
        (dict(n_substrate=float("inf")), "n_substrate"),
    ],
)
def test_invalid_film_model_raises_value_error_naming_the_field(kwargs, field):
    args = dict(name="x", cauchy_a=1.5)
    args.update(kwargs)
    with pytest.raises(ValueError, match=field):
        FilmModel(**args)


def test_unknown_film_name_lists_the_allowed_names():
    with pytest.raises(ValueError, match=r"film must be one of \['keratin', 'paper'\], got 'glass'"):
        get_film("glass")


def test_n_film_rejects_non_positive_wavelengths():
    with pytest.raises(ValueError, match="wavelength_nm"):
        FILMS["keratin"].n_film([500.0, 0.0])
