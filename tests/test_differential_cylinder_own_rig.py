"""Controllers tuned on the user's own rig (issue 54): ``controllers(params)`` and ``hydro
benchmark --params FILE`` tune the rule of :mod:`agents.controllers.differential_cylinder` on
the rig's own no-load speed and minimum hydraulic natural frequency.

Truth: the gain margins of the loops on each rig's own linearisation without dry friction
(:mod:`agents.controllers.margins`), at three positions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.controllers import make_controller
from agents.controllers.differential_cylinder import CROSSOVER_RATIO, K_DP, P_CROSSOVER_RATIO, P_K_DP, pid_tuning
from agents.controllers.differential_cylinder_tuning import loop_set, worst_margins
from hydro_envs.plants.differential_cylinder.datasheet import load_rig
from hydro_envs.plants.differential_cylinder.params import DifferentialCylinderParams

ENV = "hydro_envs/DifferentialCylinderPosition-v0"
EXAMPLE = DifferentialCylinderParams()
#: a heavy axis: a slow oil spring (omega_h 177 rad/s, a fifth of the example's) and a 60 Hz valve
HEAVY = load_rig({"bore": "125 mm", "rod": "90 mm", "stroke": "800 mm", "mass": "1500 kg",
                  "supply_pressure": "210 bar", "line_volume_1": "400 cm^3", "line_volume_2": "400 cm^3",
                  "valve": {"rated_flow": "250 L/min", "rated_pressure_drop": "70 bar", "bandwidth": "60 Hz"}})
#: a small fast axis
SMALL = load_rig({"bore": "32 mm", "rod": "18 mm", "stroke": "150 mm", "mass": "8 kg", "supply_pressure": "100 bar",
                  "line_volume_1": "20 cm^3", "line_volume_2": "20 cm^3",
                  "valve": {"rated_flow": "10 L/min", "rated_pressure_drop": "70 bar", "bandwidth": "100 Hz"}})


def _rule(params):
    return loop_set(params, CROSSOVER_RATIO, K_DP, P_CROSSOVER_RATIO * pid_tuning(params)["omega_h"], P_K_DP)


def _pid_margin(w):
    return min(v for k, v in w.items() if k.startswith("pid"))


def test_the_example_rigs_gains_are_unchanged():
    pid, p = make_controller(ENV, "pid"), make_controller(ENV, "p")
    t = pid_tuning(EXAMPLE)
    assert (pid.kp, pid.k_dp) == (t["kp"], K_DP) and p.k_dp == P_K_DP
    assert math.isclose(p.kp * t["k_q"], 25.0, rel_tol=2e-3)  # the P loop's 25 1/s


def test_the_heavy_axis_needs_its_own_gains():
    own = worst_margins(HEAVY, _rule(HEAVY))
    assert _pid_margin(own) >= 10.0 and own["p x1.00"] >= 10.0, own
    borrowed = worst_margins(HEAVY, _rule(EXAMPLE))  # the example rig's gains on the heavy axis
    assert not all(np.isfinite(v) for v in borrowed.values()), borrowed


def test_the_small_axis_keeps_its_margins():
    own = worst_margins(SMALL, _rule(SMALL))
    assert _pid_margin(own) >= 10.0 and own["p x1.00"] >= 10.0, own


@pytest.mark.parametrize("rig", [HEAVY, SMALL], ids=["heavy", "small"])
def test_controllers_are_built_with_the_rigs_gains(rig):
    t = pid_tuning(rig)
    pid, p = make_controller(ENV, "pid", rig), make_controller(ENV, "p", rig)
    assert math.isclose(pid.kp, t["kp"]) and pid.k_dp == K_DP
    assert math.isclose(p.kp, P_CROSSOVER_RATIO * t["omega_h"] / t["k_q"])
    assert not math.isclose(make_controller(ENV, "pid").kp, pid.kp)  # not the example rig's


def test_the_benchmark_tunes_on_the_parameter_file(tmp_path):
    from agents.benchmark import _rig_params

    assert _rig_params(ENV, {}) is None
    rig = _rig_params(ENV, {"params": {"bore": "125 mm", "rod": "90 mm", "mass": "1500 kg"}})
    assert math.isclose(rig.bore, 0.125) and math.isclose(rig.mass, 1500.0)


def test_plants_tuned_on_the_seed_rig_only_refuse_rig_parameters():
    with pytest.raises(ValueError, match="seed rig only"):
        make_controller("hydro_envs/ServoCylinderPosition-v0", "pid", EXAMPLE)
