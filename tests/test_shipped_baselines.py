"""No shipped learned baseline is as bad as doing nothing (issue 57 item 7).

Every committed benchmark result (``docs/benchmarks/*.json``, made by the printed commands of
``docs/benchmarks/README.md``) that scores a trivial controller (``zero`` action, or the load-
sensing pump's own ``passive`` regulation) must show each learned family (PPO, SAC, TD3 rows)
at least ``MARGIN`` below that controller's mean RMSE on every parameter set. A baseline that
is not is retrained or not shipped (``agents.pretrain.NOT_SHIPPED``).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

RESULTS = sorted((Path(__file__).resolve().parents[1] / "docs" / "benchmarks").glob("*.json"))
LEARNED = ("ppo", "sac", "td3")
#: a learned baseline must beat the trivial controller's mean RMSE by at least 5 %
MARGIN = 0.95


def _rows():
    for path in RESULTS:
        rows = json.loads(path.read_text())["controllers"]
        trivial = next((rows[k] for k in ("zero", "passive") if k in rows), None)
        if trivial is None:
            continue
        for name, row in rows.items():
            if name.startswith(LEARNED):
                yield path.stem, name, row["rmse"]["value"], trivial["rmse"]["value"]


@pytest.mark.parametrize("table,name,rmse,trivial", list(_rows()), ids=lambda v: v if isinstance(v, str) else "")
def test_learned_baseline_beats_the_trivial_controller(table, name, rmse, trivial):
    assert rmse < MARGIN * trivial, (f"{table}: {name} RMSE {rmse:.4g} is not {1 - MARGIN:.0%} below the trivial "
                                     f"controller's {trivial:.4g}: retrain it or do not ship it")


def test_baselines_named_not_shipped_are_not_shipped():
    from agents.pretrain import NOT_SHIPPED, PRETRAINED_ROOT

    for plant, tag in NOT_SHIPPED:
        assert not list((PRETRAINED_ROOT / plant).glob(f"{tag}_s*")), (plant, tag)
        assert not list((PRETRAINED_ROOT / plant).glob(f"{tag}_nominal_s*")), (plant, tag)
        assert not (PRETRAINED_ROOT / plant / f"{tag}_selected").exists(), (plant, tag)
