""":class:`Issue`, what every checker reports, and :class:`Report`, what validation returns (their own module, so
that the checkers do not depend on the validator that calls them)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Issue:
    """One problem found in an asset; only ``severity`` errors make a report unclean; ``variants`` empty: all."""

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


@dataclass
class Report:
    """Result of :func:`validate_asset`: ``clean`` when no issue is an error."""

    path: str
    issues: list = field(default_factory=list)
    variants: list = field(default_factory=list)
    counts: dict = field(default_factory=dict)

    @property
    def errors(self) -> list:
        return only_errors(self.issues)

    @property
    def clean(self) -> bool:
        return not self.errors

    def _shown(self, per_check: int) -> tuple[list, dict]:
        """The first ``per_check`` issues of each (check, severity) and how many of each were left out."""
        shown, left = [], {}
        for i in self.issues:
            key = f"{i.check} {i.severity}s"
            left[key] = left.get(key, 0) + 1
            if left[key] <= per_check:
                shown.append(i)
        return shown, {k: n - per_check for k, n in left.items() if n > per_check}

    def to_dict(self, per_check: int = 1000) -> dict:
        """JSON-ready; at most ``per_check`` issues of each check and severity, ``omitted`` counts the rest."""
        shown, left = self._shown(per_check)
        return {"path": self.path, "clean": self.clean, "variants": list(self.variants),
                "counts": dict(sorted(self.counts.items())), "issues": [i.to_dict() for i in shown],
                "n_errors": len(self.errors), "n_warnings": len(self.issues) - len(self.errors), "omitted": left}

    def format(self, per_check: int = 20) -> str:
        """A readable report: the first ``per_check`` issues of each check and severity, then a count."""
        shown, left = self._shown(per_check)
        lines = [f"{self.path}: {'clean' if self.clean else 'NOT CLEAN'} "
                 f"({len(self.errors)} error(s), {len(self.issues) - len(self.errors)} warning(s))",
                 "  variants: " + (", ".join(self.variants) or "(none)"),
                 "  checked: " + ", ".join(f"{k} {v}" for k, v in sorted(self.counts.items()))]
        for i in shown:
            where = f" [{', '.join(i.variants)}]" if i.variants else ""
            lines.append(f"  {i.severity.upper()} {i.check}: {i.path}: {i.message}{where}")
        lines += [f"  ... and {n:,} more {key} (not shown)" for key, n in left.items()]
        return "\n".join(lines)
