"""Semantics of validation rows: relative, absolute and one-sided; every row has a kind."""

import pytest

from hydro_envs.validation import ValidationRow


def row(**kw):
    base = dict(name="r", published=10.0, reproduced=10.4, tolerance=0.05, unit="1", source="s",
                kind="independent")
    base.update(kw)
    return ValidationRow(**base)


def test_relative_and_absolute_tolerances():
    assert row().passed is True  # 4 % <= 5 %
    assert row(reproduced=11.0).passed is False  # 10 % > 5 %
    assert row(published=0.0, reproduced=0.3, tolerance=0.5, absolute=True).passed is True
    assert row(published=0.0, reproduced=0.6, tolerance=0.5, absolute=True).passed is False
    assert row(reproduced=float("nan")).passed is False


def test_upper_bound_counts_only_the_excess():
    assert row(published=1.0, reproduced=0.01, tolerance=0.0, upper_bound=True).passed is True
    assert row(published=1.0, reproduced=1.0, tolerance=0.0, upper_bound=True).passed is True
    assert row(published=1.0, reproduced=1.2, tolerance=0.0, upper_bound=True).passed is False
    assert row(published=1.0, reproduced=0.5, tolerance=0.0, upper_bound=True).published_text == "< 1"


def test_bad_rows_are_refused():
    with pytest.raises(ValueError, match="kind"):
        row(kind="")
    with pytest.raises(ValueError, match="tolerance"):
        row(tolerance=-0.1)
    with pytest.raises(ValueError, match="absolute"):
        row(published=0.0)
    with pytest.raises(TypeError):
        row(report_only=True)  # no report-only rows: a deviation fails


def test_a_printed_range_passes_inside_and_measures_from_the_nearer_end():
    r = row(published=5.0, published_high=6.0, reproduced=5.75, tolerance=0.0)
    assert r.passed and r.published_text == "5-6" and r.error == 0.0
    low = row(published=5.0, published_high=6.0, reproduced=4.5, tolerance=0.0)
    assert not low.passed and abs(low.error - 0.1) < 1e-12  # 0.5 below 5
    high = row(published=7.0, published_high=9.0, reproduced=9.05, tolerance=0.0)
    assert not high.passed and abs(high.error - 0.05 / 9.0) < 1e-12
    with pytest.raises(ValueError, match="published_high"):
        row(published=6.0, published_high=5.0)


def test_a_bracket_passes_only_when_its_two_runs_enclose_the_published_number():
    r = row(published=0.327, reproduced=0.01, reproduced_high=1.5, tolerance=0.0)
    assert r.passed and r.reproduced_text == "0.01..1.5"
    assert row(published=0.327, reproduced=1.5, reproduced_high=0.01, tolerance=0.0).passed  # order-free
    above = row(published=0.327, reproduced=0.4, reproduced_high=1.5, tolerance=0.0)
    assert not above.passed and abs(above.error - (0.4 - 0.327) / 0.327) < 1e-12
    below = row(published=0.327, reproduced=0.01, reproduced_high=0.2, tolerance=0.0)
    assert not below.passed
    assert not row(published=0.327, reproduced=0.01, reproduced_high=float("nan"), tolerance=0.0).passed
    with pytest.raises(ValueError, match="exclude"):
        row(published=0.327, reproduced=0.01, reproduced_high=1.5, published_high=1.0)


def test_three_kinds_and_the_report_groups_them():
    from hydro_envs.validation import KINDS, format_table, report_dict

    assert KINDS == ("independent", "table", "consistency")
    rows = [row(name="c", kind="consistency"), row(name="t", kind="table"),
            row(name="i", kind="independent"), row(name="bad", kind="table", reproduced=20.0)]
    rep = report_dict(rows)
    assert [d["name"] for d in rep["rows"]] == ["i", "t", "bad", "c"]
    assert rep["kinds"]["table"] == {"rows": 2, "pass": 1, "names": ["t", "bad"]}
    assert rep["independent"] == 1 and rep["passed"] is False
    assert report_dict(rows[:3])["passed"] is True and report_dict([])["passed"] is False
    text = format_table(rows)
    assert text.index("independent rows (1/1") < text.index("table rows (1/2") < text.index("consistency rows (1/1")


def test_markdown_carries_the_plants_notes_after_the_rows():
    from hydro_envs.validation import format_markdown

    text = format_markdown([row(name="i")], [("rodless_cylinder", "**Eq (32), decided.** bracket")])
    assert text.index("| i |") < text.index("## Decisions and seed numbers that are not rows")
    assert "### rodless_cylinder\n\n**Eq (32), decided.** bracket" in text


def test_the_plants_document_their_decisions_and_open_seed_numbers():
    from hydro_envs.validation import validation_notes

    notes = dict(validation_notes())
    assert {"rodless_cylinder", "shaking_table", "force_actuator"} <= set(notes)
    assert "conclusion (2)" in notes["rodless_cylinder"] and "150 Hz" in notes["shaking_table"]
