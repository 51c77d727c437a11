"""One problem found in an asset (:class:`Issue`), the unit every check of :mod:`.validate`,
:mod:`.dependencies` and :mod:`.nvidia` reports in. Its own module so that those checkers depend on it and
not on the validator that calls them (``rockdove.usd.validate`` re-exports it).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Issue:
    """One problem found in an asset.

    Attributes
    ----------
    check : str
        ``usdValidation:<validator>:<error name>``, ``mtlx``, ``texture``, ``primvar``, ``thinFilm``,
        ``material`` or ``open``.
    path : str
        Prim or property path (or file) the problem is about.
    message : str
        What is wrong: the value found and what was expected.
    severity : str
        ``error`` or ``warning``; only errors make a report unclean.
    variants : tuple of str
        Variant selections (``shading=baked``...) in which it was found; empty when not variant-specific.
    """

    check: str
    path: str
    message: str
    severity: str = "error"
    variants: tuple = ()

    def to_dict(self) -> dict:
        return {"check": self.check, "path": self.path, "message": self.message, "severity": self.severity,
                "variants": list(self.variants)}


def only_errors(issues) -> list:
    """The issues of severity ``error``, the ones that make an asset unclean."""
    return [i for i in issues if i.severity == "error"]
