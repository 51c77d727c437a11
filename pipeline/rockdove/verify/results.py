"""The verification's results as typed values: what its checks hand on, what its cache keeps and the
:class:`Report`. Each ``to_json()`` is its part of ``report.json``; ``from_json`` reads it back (:func:`read`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

from ..usd.issues import Issue
from .records import Record, plain, read

if TYPE_CHECKING:  # compare imports numpy; the build's verdict and the API's types need none of it
    from .boundary import Boundary, BoundaryShape
    from .compare import HueHistogram, ViewMetrics


def type_names() -> dict[str, Any]:
    """The names above imported only when type checking, for :func:`.records.read` to resolve the fields' types."""
    from . import boundary, compare

    return {**vars(compare), **vars(boundary)}


#: A host's outcome: within its goals, not, not run here (``reason`` why), or it raised (``reason`` its error).
Status = Literal["passed", "failed", "skipped", "error"]


@dataclass(frozen=True)
class ViewResult(Record):
    """One verification view: its GL render against the exact reference (``metrics`` None when the render
    failed), the light sweep's hues and boundary, its images in ``folder`` and its contact-sheet row."""

    view: str
    setup: dict
    sweep: bool
    metrics: ViewMetrics | None
    failures: tuple[str, ...]
    reference: dict
    hue: HueHistogram | None
    boundary: BoundaryShape | None
    files: dict[str, str]
    timings_s: dict[str, float]
    folder: str = field(default="", compare=False)
    sheet_row: tuple = field(default=(), compare=False, repr=False)
    _PRIVATE = ("folder", "sheet_row")

    @classmethod
    def from_json(cls, data: dict, folder: str = "", sheet_row: tuple = ()) -> ViewResult:
        return dataclasses.replace(super().from_json(data), folder=folder, sheet_row=tuple(sheet_row))


@dataclass(frozen=True)
class DeStats:
    """CIEDE2000 over a host's compared pixels (NaN without any)."""

    n_pixels: int
    median_dE: float
    p95_dE: float


@dataclass(frozen=True, kw_only=True)
class HostMetrics(DeStats):
    """One host's renders against the reference of its lobe (:mod:`rockdove.verify.host_check`), and by view."""

    green_px: int
    purple_px: int
    hue_agreement: float
    per_view: dict[str, DeStats]


@dataclass(frozen=True)
class Goals:
    """What each view must meet (:mod:`rockdove.verify.compare`), and the share of the light sweep each hue needs."""

    median_dE: float
    p95_dE: float
    black_fraction: float
    min_hue_fraction: float


@dataclass(frozen=True)
class HostResult:
    """One host's check: ``reason`` why it was skipped, or its error; ``variant`` and ``lobe`` None for a host not
    available here; ``files``: ``{view: {"host", "reference", "dE": file name}}``."""

    name: str
    status: Status
    variant: str | None = None
    lobe: str | None = None
    reason: str | None = None
    metrics: HostMetrics | None = None
    failures: tuple[str, ...] = ()
    files: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def passed(self) -> bool | None:
        """True or False for a host that ran, None for one skipped."""
        return None if self.status == "skipped" else self.status == "passed"

    def to_json(self) -> dict:
        """The report's host entry: name, variant, lobe, then the metrics, ``passed`` and ``failures`` (a skip:
        ``skipped`` and ``reason``; an error: ``error``)."""
        out: dict = {"name": self.name}
        out.update({} if self.variant is None else {"variant": self.variant, "lobe": self.lobe})
        if self.status == "skipped":
            return {**out, "skipped": True, "reason": self.reason, "passed": None}
        if self.status == "error":
            return {**out, "passed": False, "error": self.reason}
        return {**out, **plain(self.metrics), "passed": self.passed, "failures": list(self.failures)}

    @classmethod
    def from_json(cls, data: dict, files: dict | None = None) -> HostResult:
        data = dict(data)
        common = {"name": data.pop("name"), "variant": data.pop("variant", None), "lobe": data.pop("lobe", None),
                  "files": files or {}}
        if data.get("skipped"):
            return cls(status="skipped", reason=data["reason"], **common)
        if "error" in data:
            return cls(status="error", reason=data["error"], **common)
        passed, failures = data.pop("passed"), tuple(data.pop("failures", ()))
        return cls(status="passed" if passed else "failed", metrics=read(HostMetrics, data), failures=failures,
                   reason="; ".join(failures) or None, **common)


@dataclass(frozen=True)
class ItemNames:
    """The verification's cache items of one run by kind (surfaces by camera key, the others by name)."""

    surfaces: tuple[str, ...] = ()
    views: tuple[str, ...] = ()
    hosts: tuple[str, ...] = ()
    pictures: tuple[str, ...] = ()


@dataclass(frozen=True)
class ItemsUsed:
    """Which of the verification's items were rendered (``ran``) and which came from its cache (``reused``)."""

    ran: ItemNames = ItemNames()
    reused: ItemNames = ItemNames()


@dataclass(frozen=True)
class Validation:
    """The asset validator's verdict: ``details`` its report (issues, counts), ``error`` when it could not run."""

    passed: bool
    details: dict | None
    error: str | None

    @property
    def issues(self) -> tuple[Issue, ...]:
        return tuple(Issue(**i) for i in (self.details or {}).get("issues", ()))


@dataclass(frozen=True)
class Measure:
    """An anatomy measure beside its range (:data:`rockdove.verify.anatomy.RANGES`); ``value`` None: NaN read back."""

    name: str
    value: float | None
    low: float | None
    high: float | None
    unit: str
    source: str
    what: str
    passed: bool


@dataclass(frozen=True)
class Anatomy(Record):
    """The bird against its published measures (:mod:`rockdove.verify.anatomy`); none when it cannot be measured."""

    passed: bool
    failures: tuple[str, ...]
    measures: tuple[Measure, ...] = ()


@dataclass(frozen=True)
class MotionCheck(Record):
    """A motion measured at every time code (:func:`rockdove.verify.motion.measure_motion`), its measures and their
    limits by name, the film checked at ``times`` in ``views``; the report's ``animation`` or ``notes`` why none."""

    motion: str
    frames: int
    measures: dict[str, float]
    limits: dict
    failures: tuple[str, ...]
    times: tuple[float, ...] = ()
    views: tuple[str, ...] = ()
    animation: dict | None = None
    notes: tuple[str, ...] | None = None

    def to_json(self) -> dict:
        return {k: v for k, v in super().to_json().items() if v is not None}


@dataclass(frozen=True)
class Report(Record):
    """A verification: report.json's content (``to_json``), typed where it is read. ``cache``: the items that ran
    and were reused."""

    asset: str
    asset_sha256: str
    out_dir: str
    passed: bool
    failures: tuple[str, ...]
    notes: tuple[str, ...]
    goals: Goals
    validation: Validation
    views: tuple[ViewMetrics, ...]
    views_reused: tuple[str, ...]
    cache: ItemsUsed
    view_setup: tuple[dict, ...]
    reference: tuple[dict, ...]
    hue_sweep: HueHistogram
    hosts: tuple[HostResult, ...]
    anatomy: Anatomy
    beauty: dict | None
    boundary: Boundary
    film: dict | None
    lut: dict | None
    variants: dict[str, str]
    configuration: dict
    configuration_hash: str | None
    render: dict
    timings_s: dict[str, float]
    versions: dict
    argv: tuple[str, ...]
    motion: MotionCheck | None = None
    animation: dict | None = None  # the light turning round the bird (rockdove.render.animation.for_report)


@dataclass(frozen=True)
class Verdict(Record):
    """The build's verification, its stage's value: ``reason`` the failures joined."""

    passed: bool
    reason: str = ""
    views: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    items: ItemsUsed = ItemsUsed()

    @classmethod
    def of(cls, report: Report, notes: Iterable[str] = ()) -> Verdict:
        return cls(report.passed, "; ".join(report.failures), tuple(m.view for m in report.views),
                   (*report.notes, *notes), report.cache)
