"""Validation report: the project's models against numbers they did not produce.

Each row names a quantity, the value a seed, data sheet or measurement gives (``published``),
the value our simulation reproduces, the tolerance and whether it passes. Every row is one of
three kinds, by what it proves:

* ``independent``: a number printed in a seed, a data sheet or measured data, reproduced by
  *simulating* the plant through a route that does not take that number as input (the model's
  parameters may come from other printed numbers);
* ``table``: arithmetic on the seeds' tables (a closed form evaluated on printed or backed-out
  values, two printed numbers against each other); it checks the reading of the tables, not
  the dynamics;
* ``consistency``: the model against its own linearisation, closed form, inputs or a number its
  constants were calibrated on (it guards the implementation, not the physics).

A row compares one number with one number (relative or absolute tolerance), with a one-sided
bound, with a printed range (``published_high``: the paper's "between 5 and 6"), or is a
*bracket* (``reproduced_high``): two simulations that set the model's physics to the two ends
of what the seed leaves open must enclose the printed number.

There are no report-only rows: a row outside its tolerance fails the report until the model
is fixed, and the report's verdict is the AND of every row. ``hydro validate`` prints the
table grouped by kind, ``--json`` one JSON object, ``--markdown`` the documentation page.
Each plant's ``validation.py`` gives its rows (``rows()``); other packages add providers
through the ``hydro_envs.validation`` entry points.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Callable

__all__ = ["ValidationRow", "KINDS", "run_validation", "row_providers", "ENTRY_POINT_GROUP",
           "format_table", "format_markdown", "report_dict", "validation_notes"]

#: the two kinds of row (see the module docstring), in report order
KINDS: tuple[str, ...] = ("independent", "table", "consistency")


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
    #: one-sided check: ``published`` is an upper bound (e.g. the paper's direction "ratio
    #: below 1"); only an excess over it counts as error
    upper_bound: bool = False
    #: ``independent``, ``table`` or ``consistency`` (see the module docstring); required
    kind: str = ""
    #: a printed range ``[published, published_high]``: only a reproduction outside it counts
    #: as error (relative to the nearer end, or absolute)
    published_high: float | None = None
    #: a bracket: ``reproduced`` and ``reproduced_high`` are two simulations (the two ends of
    #: what the seed leaves open); the row passes when they enclose ``published``
    reproduced_high: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"ValidationRow {self.name!r}: kind={self.kind!r}; allowed: {', '.join(KINDS)}")
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0.0):
            raise ValueError(f"ValidationRow {self.name!r}: tolerance={self.tolerance!r}; allowed: finite, >= 0")
        if not self.absolute and not self.upper_bound and self.published == 0.0:
            raise ValueError(f"ValidationRow {self.name!r}: published=0 needs absolute=True (relative error undefined)")
        shapes = sum((self.upper_bound, self.published_high is not None, self.reproduced_high is not None))
        if shapes > 1:
            raise ValueError(f"ValidationRow {self.name!r}: upper_bound, published_high and reproduced_high "
                             "exclude each other")
        if self.published_high is not None and not self.published_high > self.published:
            raise ValueError(f"ValidationRow {self.name!r}: published_high={self.published_high!r}; "
                             f"allowed: > published ({self.published!r})")

    def _deviation(self) -> tuple[float, float]:
        """(signed distance outside the accepted set, the scale of a relative error)."""
        if self.reproduced_high is not None:
            lo, hi = sorted((self.reproduced, self.reproduced_high))
            d = lo - self.published if self.published < lo else max(self.published - hi, 0.0)
            return d, abs(self.published)
        if self.published_high is not None:
            if self.reproduced < self.published:
                return self.published - self.reproduced, abs(self.published)
            return max(self.reproduced - self.published_high, 0.0), abs(self.published_high)
        diff = self.reproduced - self.published
        return (max(diff, 0.0) if self.upper_bound else diff), abs(self.published)

    @property
    def error(self) -> float:
        diff, scale = self._deviation()
        if self.absolute:
            return abs(diff)
        return abs(diff) / scale

    @property
    def passed(self) -> bool:
        """Within tolerance (a non-finite reproduction fails)."""
        finite = math.isfinite(self.reproduced) and (self.reproduced_high is None or math.isfinite(self.reproduced_high))
        return bool(finite and self.error <= self.tolerance)

    @property
    def status(self) -> str:
        return "PASS" if self.passed else "FAIL"

    @property
    def published_text(self) -> str:
        """The published value as shown: ``< 1`` for an upper bound, ``5-6`` for a range."""
        if self.published_high is not None:
            return f"{self.published:.4g}-{self.published_high:.4g}"
        return f"< {self.published:.4g}" if self.upper_bound else f"{self.published:.4g}"

    @property
    def reproduced_text(self) -> str:
        """The reproduction as shown: ``0.01..1.5`` for a bracket."""
        if self.reproduced_high is not None:
            lo, hi = sorted((self.reproduced, self.reproduced_high))
            return f"{lo:.3g}..{hi:.3g}"
        return f"{self.reproduced:.4g}"

    @property
    def tolerance_text(self) -> str:
        if self.tolerance == 0.0 and (self.upper_bound or self.published_high is not None
                                      or self.reproduced_high is not None):
            return "-"
        if self.absolute:
            return f"+-{self.tolerance:.3g} {self.unit}".rstrip()
        return f"{100.0 * self.tolerance:.3g} %"

    @property
    def error_text(self) -> str:
        if not (math.isfinite(self.reproduced) and math.isfinite(self.reproduced_high or 0.0)):
            return "n/a"
        if self.absolute:
            return f"{self.error:.3g} {self.unit}".rstrip()
        if self.upper_bound or self.published_high is not None or self.reproduced_high is not None:
            return "0" if self.error == 0.0 else f"{self.error:.3g}"
        return f"{100.0 * self.error:.2g} %"

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


def validation_notes() -> list[tuple[str, str]]:
    """(plant, markdown) of every plant whose ``validation.py`` has a ``NOTES`` string: the
    decisions behind its rows and the seed numbers that are not rows, with the reason."""
    from hydro_envs import registry

    out = []
    for spec in registry.specs():
        if spec.has_module("validation"):
            text = getattr(spec.module("validation"), "NOTES", "")
            if text:
                out.append((spec.name, text.strip()))
    return out


def run_validation() -> list[ValidationRow]:
    """Compute every validation row (:func:`row_providers`)."""
    rows: list[ValidationRow] = []
    for _name, func in row_providers():
        rows.extend(func())
    return rows


def report_dict(rows: list[ValidationRow]) -> dict:
    """The report as one JSON-ready object: ``rows`` grouped by kind (``KINDS`` order, each with
    its ``kind``), ``kinds`` (per kind the row names, their count and passes), ``independent``
    (the count of independent rows) and ``passed``, the AND of every row (False for no rows)."""
    groups = {k: [r for r in rows if r.kind == k] for k in KINDS}
    return {
        "passed": bool(rows) and all(r.passed for r in rows),
        "independent": len(groups["independent"]),
        "kinds": {k: {"rows": len(g), "pass": sum(r.passed for r in g), "names": [r.name for r in g]}
                  for k, g in groups.items()},
        "rows": [r.as_dict() for k in KINDS for r in groups[k]],
    }


def _clip(text: str, width: int) -> str:
    return text if len(text) <= width else text[: width - 1] + "~"


def format_table(rows: list[ValidationRow], width: int = 120) -> str:
    """The rows as a text table within ``width`` columns, grouped by kind, then a summary line.

    Columns: name, published, reproduced, unit, error, tolerance, PASS/FAIL (sources are in
    ``--json`` and ``--markdown``; long names are clipped with ``~``)."""
    fixed = [("published", 10), ("reproduced", 12), ("unit", 8), ("error", 9), ("tolerance", 10), ("result", 6)]
    name_w = width - sum(w + 1 for _, w in fixed)
    lines: list[str] = []
    for kind in KINDS:
        group = [r for r in rows if r.kind == kind]
        if not group:
            continue
        n_pass = sum(r.passed for r in group)
        lines.append(f"{kind} rows ({n_pass}/{len(group)} pass)")
        head = [f"{'check':<{name_w}}"] + [f"{h:>{w}}" if h != "unit" else f"{h:<{w}}" for h, w in fixed]
        lines.append(" ".join(head))
        lines.append("-" * width)
        for r in group:
            cells = [r.published_text, r.reproduced_text, r.unit, r.error_text, r.tolerance_text, r.status]
            out = [f"{_clip(r.name, name_w):<{name_w}}"]
            for (h, w), c in zip(fixed, cells):
                out.append(f"{_clip(c, w):<{w}}" if h == "unit" else f"{_clip(c, w):>{w}}")
            lines.append(" ".join(out).rstrip())
        lines.append("")
    n_pass = sum(r.passed for r in rows)
    n_ind = sum(r.kind == "independent" for r in rows)
    verdict = "passed" if rows and n_pass == len(rows) else "FAILED"
    lines.append(f"{n_pass}/{len(rows)} rows pass ({n_ind} independent); validation {verdict}")
    return "\n".join(lines)


def _md(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def format_markdown(rows: list[ValidationRow], notes: Sequence[tuple[str, str]] = ()) -> str:
    """The documentation page: every row with its kind, numbers, verdict and source, then the
    plants' ``notes`` (:func:`validation_notes`)."""
    n_pass = sum(r.passed for r in rows)
    out = [
        "# Validation against the seeds",
        "",
        "Generated by `hydro validate --markdown docs/validation.md`; do not edit by hand.",
        "",
        "* **independent**: a number printed in a seed, a data sheet or measured data, reproduced",
        "  by simulating the plant through a route that does not take that number as input;",
        "* **table**: arithmetic on the seeds' tables (it checks the reading of the tables, not the",
        "  dynamics);",
        "* **consistency**: the model against its own linearisation, closed form, inputs or a number",
        "  its constants were calibrated on.",
        "",
        "A row outside its tolerance fails the report; there are no report-only rows. A range",
        "(`5-6`) passes when the reproduction lies in it; a bracket (`lo..hi`, two simulations at",
        "the two ends of what the seed leaves open) when it encloses the published number.",
        "",
        f"**{n_pass}/{len(rows)} rows pass; "
        + ", ".join(f"{sum(r.kind == k for r in rows)} {k}" for k in KINDS) + ".**",
        "",
    ]
    for kind in KINDS:
        group = [r for r in rows if r.kind == kind]
        if not group:
            continue
        out += [f"## {kind.capitalize()} rows", "",
                "| check | published | reproduced | unit | error | tolerance | result | source |",
                "|---|---|---|---|---|---|---|---|"]
        for r in group:
            out.append(f"| {_md(r.name)} | {_md(r.published_text)} | {_md(r.reproduced_text)} | {_md(r.unit)} | "
                       f"{_md(r.error_text)} | {_md(r.tolerance_text)} | {r.status} | {_md(r.source)} |")
        out.append("")
    if notes:
        out += ["## Decisions and seed numbers that are not rows", ""]
        for plant, text in notes:
            out += [f"### {plant}", "", text, ""]
    return "\n".join(out)
