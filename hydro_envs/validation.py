"""Validation report: the project's models against the numbers published in the seeds.

Each row names a published quantity, the value the seed gives (or that follows from the
seed's printed data by the law the seed states), the value our simulation reproduces, the
tolerance and whether it passes. Rows marked ``report_only`` are comparisons an issue asks to
report with the difference explained (a known deviation of the model from the paper): they
show their error and never count as pass or fail. ``hydro validate`` prints the table;
``--json`` prints it as one JSON object. Each plant's ``validation.py`` gives its rows
(``rows()``); other packages add providers through the ``hydro_envs.validation`` entry points.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

__all__ = ["ValidationRow", "run_validation", "row_providers", "ENTRY_POINT_GROUP"]


@dataclasses.dataclass(frozen=True)
class ValidationRow:
    name: str
    published: float
    reproduced: float
    tolerance: float  # relative (or absolute, in ``unit``, when ``absolute`` is set)
    unit: str
    source: str
    #: compare ``|reproduced - published| <= tolerance`` instead of the relative error (for
    #: published values of 0, e.g. the location of a minimum)
    absolute: bool = False
    #: a comparison the issue asks to *report* with the difference explained in ``source``
    #: (e.g. a known model deviation): shown with its error, never counted as pass or fail
    report_only: bool = False
    #: one-sided check: ``published`` is an upper bound (e.g. the paper's direction "ratio
    #: below 1"); only an excess over it counts as error
    upper_bound: bool = False

    @property
    def error(self) -> float:
        diff = self.reproduced - self.published
        if self.upper_bound:
            diff = max(diff, 0.0)
        if self.absolute:
            return abs(diff)
        return abs(diff) / abs(self.published)

    @property
    def within_tolerance(self) -> bool:
        return bool(math.isfinite(self.reproduced) and self.error <= self.tolerance)

    @property
    def passed(self) -> bool | None:
        """True/False for checks; None for report-only rows."""
        return None if self.report_only else self.within_tolerance

    @property
    def status(self) -> str:
        if self.report_only:
            return "REPORT"
        return "PASS" if self.passed else "FAIL"

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["relative_error"] = None if self.absolute else self.error
        d["error"] = self.error  # absolute rows: |reproduced - published| in ``unit``
        d["passed"] = self.passed
        d["status"] = self.status
        return d


#: entry-point group of row providers outside the plants (callables returning rows)
ENTRY_POINT_GROUP = "hydro_envs.validation"


def row_providers() -> list[tuple[str, Callable[[], list[ValidationRow]]]]:
    """(name, function) of every row provider: each plant's ``validation.rows`` in registry
    order, then the functions installed under the ``hydro_envs.validation`` entry points."""
    from importlib.metadata import entry_points

    from hydro_envs import registry

    out: list[tuple[str, Callable[[], list[ValidationRow]]]] = [
        (spec.name, spec.validation_rows) for spec in registry.specs() if spec.has_module("validation")
    ]
    for ep in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        out.append((ep.name, ep.load()))
    return out


def run_validation() -> list[ValidationRow]:
    """Compute every validation row (:func:`row_providers`)."""
    rows: list[ValidationRow] = []
    for _name, func in row_providers():
        rows.extend(func())
    return rows
