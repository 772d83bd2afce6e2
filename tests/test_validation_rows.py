"""Semantics of validation rows: relative, absolute, one-sided and report-only."""

from hydro_envs.validation import ValidationRow


def row(**kw):
    base = dict(name="r", published=10.0, reproduced=10.4, tolerance=0.05, unit="1", source="s")
    base.update(kw)
    return ValidationRow(**base)


def test_relative_and_absolute_tolerances():
    assert row().passed is True  # 4 % <= 5 %
    assert row(reproduced=11.0).passed is False  # 10 % > 5 %
    assert row(published=0.0, reproduced=0.3, tolerance=0.5, absolute=True).passed is True
    assert row(published=0.0, reproduced=0.6, tolerance=0.5, absolute=True).passed is False


def test_upper_bound_counts_only_the_excess():
    assert row(published=1.0, reproduced=0.01, tolerance=0.0, upper_bound=True).passed is True
    assert row(published=1.0, reproduced=1.0, tolerance=0.0, upper_bound=True).passed is True
    assert row(published=1.0, reproduced=1.2, tolerance=0.0, upper_bound=True).passed is False


def test_report_only_rows_are_neither_pass_nor_fail():
    r = row(reproduced=20.0, report_only=True)
    assert r.passed is None and r.status == "REPORT" and r.within_tolerance is False
    assert r.as_dict()["status"] == "REPORT"
