"""Validation report: the project's models against numbers they did not produce.

Each row names a quantity, the value a seed, data sheet or measurement gives (``published``),
the value our simulation reproduces, the tolerance and whether it passes. Every row is one of
two kinds:

* ``independent``: a number printed in a seed, a data sheet or measured data, reproduced by a
  route that does not take it as input (the model's own parameters may come from other
  printed numbers);
* ``consistency``: the model against its own linearisation, closed form or inputs (it guards
  the implementation, not the physics).

There are no report-only rows: a row outside its tolerance fails the report until the model
is fixed, and the report's verdict is the AND of every row. ``hydro validate`` prints the
table grouped by kind, ``--json`` one JSON object, ``--markdown`` the documentation page.
Each plant's ``validation.py`` gives its rows (``rows()``); other packages add providers
through the ``hydro_envs.validation`` entry points.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

__all__ = ["ValidationRow", "KINDS", "run_validation", "row_providers", "ENTRY_POINT_GROUP",
           "format_table", "format_markdown"]

#: the two kinds of row (see the module docstring), in report order
KINDS: tuple[str, ...] = ("independent", "consistency")


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
    #: ``independent`` or ``consistency`` (see the module docstring); required
    kind: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"ValidationRow {self.name!r}: kind={self.kind!r}; allowed: {', '.join(KINDS)}")
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0.0):
            raise ValueError(f"ValidationRow {self.name!r}: tolerance={self.tolerance!r}; allowed: finite, >= 0")
        if not self.absolute and not self.upper_bound and self.published == 0.0:
            raise ValueError(f"ValidationRow {self.name!r}: published=0 needs absolute=True (relative error undefined)")

    @property
    def error(self) -> float:
        diff = self.reproduced - self.published
        if self.upper_bound:
            diff = max(diff, 0.0)
        if self.absolute:
            return abs(diff)
        return abs(diff) / abs(self.published)

    @property
    def passed(self) -> bool:
        """Within tolerance (a non-finite reproduction fails)."""
        return bool(math.isfinite(self.reproduced) and self.error <= self.tolerance)

    @property
    def status(self) -> str:
        return "PASS" if self.passed else "FAIL"

    @property
    def published_text(self) -> str:
        """The published value as shown: ``< 1`` for an upper bound."""
        return f"< {self.published:.4g}" if self.upper_bound else f"{self.published:.4g}"

    @property
    def tolerance_text(self) -> str:
        if self.upper_bound and self.tolerance == 0.0:
            return "-"
        if self.absolute:
            return f"+-{self.tolerance:.3g} {self.unit}".rstrip()
        return f"{100.0 * self.tolerance:.3g} %"

    @property
    def error_text(self) -> str:
        if not math.isfinite(self.reproduced):
            return "n/a"
        if self.absolute:
            return f"{self.error:.3g} {self.unit}".rstrip()
        if self.upper_bound:
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


def run_validation() -> list[ValidationRow]:
    """Compute every validation row (:func:`row_providers`)."""
    rows: list[ValidationRow] = []
    for _name, func in row_providers():
        rows.extend(func())
    return rows


def _clip(text: str, width: int) -> str:
    return text if len(text) <= width else text[: width - 1] + "~"


def format_table(rows: list[ValidationRow], width: int = 120) -> str:
    """The rows as a text table within ``width`` columns, grouped by kind, then a summary line.

    Columns: name, published, reproduced, unit, error, tolerance, PASS/FAIL (sources are in
    ``--json`` and ``--markdown``; long names are clipped with ``~``)."""
    fixed = [("published", 10), ("reproduced", 10), ("unit", 8), ("error", 9), ("tolerance", 10), ("result", 6)]
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
            cells = [r.published_text, f"{r.reproduced:.4g}", r.unit, r.error_text, r.tolerance_text, r.status]
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


def format_markdown(rows: list[ValidationRow]) -> str:
    """The documentation page: every row with its kind, numbers, verdict and source."""
    n_pass = sum(r.passed for r in rows)
    out = [
        "# Validation against the seeds",
        "",
        "Generated by `hydro validate --markdown docs/validation.md`; do not edit by hand.",
        "",
        "* **independent**: a number printed in a seed, a data sheet or measured data, reproduced",
        "  by a route that does not take it as input;",
        "* **consistency**: the model against its own linearisation, closed form or inputs.",
        "",
        "A row outside its tolerance fails the report; there are no report-only rows.",
        "",
        f"**{n_pass}/{len(rows)} rows pass; {sum(r.kind == 'independent' for r in rows)} independent.**",
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
            out.append(f"| {_md(r.name)} | {_md(r.published_text)} | {r.reproduced:.4g} | {_md(r.unit)} | "
                       f"{_md(r.error_text)} | {_md(r.tolerance_text)} | {r.status} | {_md(r.source)} |")
        out.append("")
    return "\n".join(out)
