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
