"""The examples in the docstrings of the public functions of api, optics and lut run, as colour-science's do."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import rockdove.lut

MODULES = ["rockdove.api", "rockdove.optics",
           *(f"rockdove.lut.{m.name}" for m in pkgutil.iter_modules(rockdove.lut.__path__))]


@pytest.mark.parametrize("name", MODULES)
def test_the_docstring_examples_run(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"


def test_api_optics_and_lut_have_examples():
    finder = doctest.DocTestFinder()
    counted = {name: sum(len(t.examples) for t in finder.find(importlib.import_module(name))) for name in MODULES}
    assert counted["rockdove.api"] and counted["rockdove.optics"] >= 5 and counted["rockdove.lut.bake"]
