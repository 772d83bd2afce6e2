"""Choosing one training seed on validation draws (agents/select_policy.py) and the shipped
``*_selected`` folders: each is a byte copy of the member its selection.json names, chosen on
draws other than the benchmark's."""

import json
from pathlib import Path

import pytest

from agents.benchmark_cli import load_config
from agents.select_policy import SELECTED_SUFFIX, _members, choose, select_policy

PRETRAINED = Path(__file__).resolve().parents[1] / "agents" / "pretrained"
SHIPPED = sorted(PRETRAINED.glob(f"*/*{SELECTED_SUFFIX}"))


def test_choose_takes_the_lowest_ratio_among_members_failing_no_more_than_the_pid():
    scores = {"a_s0": {"ratio": 0.80, "failure": 0.30}, "a_s1": {"ratio": 0.86, "failure": 0.20},
              "a_s2": {"ratio": 0.90, "failure": 0.10}}
    assert choose(scores, pid_failure=0.25) == "a_s1"  # a_s0 is better but fails more often than the PID
    assert choose(scores, pid_failure=0.30) == "a_s0"
    tie = {"b_s0": {"ratio": 0.9, "failure": 0.0}, "b_s1": {"ratio": 0.9, "failure": 0.0}}
    assert choose(tie, 0.0) == "b_s0"


def test_choose_refuses_when_every_member_fails_more_often_than_the_pid():
    with pytest.raises(ValueError, match="no member fails as rarely as the PID"):
        choose({"a_s0": {"ratio": 0.5, "failure": 0.4}}, pid_failure=0.1)


def test_members_need_two_seeds_and_validation_needs_other_draws():
    with pytest.raises(ValueError, match="need at least 2"):
        _members(["agents/pretrained/rodless_cylinder/ppo_residual_s0"], "ppo_residual")
    seed = int(load_config("force_actuator").get("seed", 0))
    with pytest.raises(ValueError, match="benchmark's own seed"):
        select_policy("force_actuator", "ppo_residual", seed=seed, dry_run=True)


def test_shipped_selections_are_listed_in_their_benchmark_config():
    assert len(SHIPPED) >= 4
    for folder in SHIPPED:
        cfg = load_config(folder.parent.name)
        assert f"agents/pretrained/{folder.parent.name}/{folder.name}" in cfg["policies"], folder


@pytest.mark.parametrize("folder", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_shipped_selection_is_a_copy_of_its_chosen_member_chosen_off_the_benchmark_draws(folder):
    rec = json.loads((folder / "selection.json").read_text())
    cfg = load_config(folder.parent.name)
    assert rec["validation"]["seed"] != int(cfg.get("seed", 0))
    assert rec["chosen"] in rec["members"] and len(rec["members"]) >= 2
    assert rec["chosen"] == choose(rec["members"], rec["pid_failure"])
    member = folder.parent / rec["chosen"]
    for name in ("policy.pt", "obs_normalization.npz", "config.yml"):
        assert (folder / name).read_bytes() == (member / name).read_bytes(), name
