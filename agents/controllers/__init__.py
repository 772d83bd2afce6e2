"""Classical controllers for every hydro_envs environment (issue 7, item 1).

All are policy objects with the SB3-style ``predict(obs, state=None, episode_start=None,
deterministic=True) -> (action, state)`` for a single observation or a batch, tuned on the
*nominal* plant from its linearisation (rules and numbers in each module's docstring):

=============================  ===========================================================
env                            controllers (:data:`CONTROLLERS` names)
=============================  ===========================================================
ServoCylinderPosition-v0       zero, p, pid, pid_ff_stribeck, pid_ff_neural, flow
                               (:mod:`agents.controllers.servo`)
ShakingTable-v0                zero, pid, pid_ff_stribeck, pid_ff_neural, flow
                               (:mod:`agents.controllers.table`)
ForceActuator-v0               zero, pid (:mod:`agents.controllers.force`)
LoadSensing-v0                 passive (= zero: the hydro-mechanical compensator alone), pid
                               (:mod:`agents.controllers.load_sensing`)
RodlessCylinder-v0             zero, pid, pid_ff_stribeck, pid_ff_neural
                               (:mod:`agents.controllers.rodless`)
=============================  ===========================================================

``pid_ff_stribeck`` / ``pid_ff_neural`` use friction models identified from virtual
constant-velocity experiments (:mod:`agents.controllers.friction_models`). ``flow`` is the
model-based nonlinear controller (flow feedback linearisation through the inverse orifice law).
:func:`make_controller` builds one by env id and name.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from agents.controllers.core import BaseController, PIDCore
from agents.controllers.servo import (
    DT,
    ZETA_H,
    PIDController,
    PIDFrictionFeedforwardController,
    ServoFlowController,
    nominal_stribeck,
    pid_tuning,
)

__all__ = [
    "CONTROLLERS",
    "DT",
    "ZETA_H",
    "BaseController",
    "PIDController",
    "PIDCore",
    "PIDFrictionFeedforwardController",
    "ServoFlowController",
    "ZeroController",
    "controller_names",
    "make_controller",
    "nominal_stribeck",
    "pid_tuning",
]


class ZeroController:
    """Action 0 for every copy (``action_dim`` wide): the do-nothing reference."""

    def __init__(self, action_dim: int = 1) -> None:
        self.action_dim = int(action_dim)

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(obs)
        if obs.ndim == 1:
            return np.zeros(self.action_dim, dtype=np.float32), state
        return np.zeros((obs.shape[0], self.action_dim), dtype=np.float32), state


def _servo() -> dict[str, Callable[[], Any]]:
    from agents.controllers.friction_models import identified_friction
    from agents.controllers.servo import ProportionalPositionController

    return {
        "zero": lambda: ZeroController(1),
        "p": ProportionalPositionController,
        "pid": PIDController.from_params,
        "pid_ff_stribeck": lambda: PIDFrictionFeedforwardController.from_params(
            model=identified_friction("servo_cylinder", "stribeck")),
        "pid_ff_neural": lambda: PIDFrictionFeedforwardController.from_params(
            model=identified_friction("servo_cylinder", "neural")),
        "flow": ServoFlowController,
    }


def _table() -> dict[str, Callable[[], Any]]:
    from agents.controllers.friction_models import identified_friction
    from agents.controllers.table import (
        TableFlowController,
        TableFrictionFeedforwardController,
        TablePIDController,
    )

    return {
        "zero": lambda: ZeroController(1),
        "pid": TablePIDController.from_params,
        "pid_ff_stribeck": lambda: TableFrictionFeedforwardController.from_params(
            model=identified_friction("shaking_table", "stribeck")),
        "pid_ff_neural": lambda: TableFrictionFeedforwardController.from_params(
            model=identified_friction("shaking_table", "neural")),
        "flow": TableFlowController,
    }


def _force() -> dict[str, Callable[[], Any]]:
    from agents.controllers.force import ForcePIDController

    return {"zero": lambda: ZeroController(1), "pid": ForcePIDController.from_params}


def _load_sensing() -> dict[str, Callable[[], Any]]:
    from agents.controllers.load_sensing import (
        LoadSensingPIDController,
        PassiveCompensatorBaseline,
    )

    return {"passive": PassiveCompensatorBaseline, "zero": PassiveCompensatorBaseline,
            "pid": LoadSensingPIDController.from_params}


def _rodless() -> dict[str, Callable[[], Any]]:
    from agents.controllers.friction_models import identified_friction
    from agents.controllers.rodless import (
        RodlessFrictionFeedforwardController,
        RodlessPIDController,
    )

    return {
        "zero": lambda: ZeroController(1),
        "pid": RodlessPIDController.from_params,
        "pid_ff_stribeck": lambda: RodlessFrictionFeedforwardController.from_params(
            model=identified_friction("rodless_cylinder", "stribeck")),
        "pid_ff_neural": lambda: RodlessFrictionFeedforwardController.from_params(
            model=identified_friction("rodless_cylinder", "neural")),
    }


#: env id -> function returning {controller name: zero-argument factory}
CONTROLLERS: dict[str, Callable[[], dict[str, Callable[[], Any]]]] = {
    "hydro_envs/ServoCylinderPosition-v0": _servo,
    "hydro_envs/ShakingTable-v0": _table,
    "hydro_envs/ForceActuator-v0": _force,
    "hydro_envs/LoadSensing-v0": _load_sensing,
    "hydro_envs/RodlessCylinder-v0": _rodless,
}


def controller_names(env_id: str) -> tuple[str, ...]:
    """Classical controller names available for ``env_id``."""
    if env_id not in CONTROLLERS:
        raise ValueError(f"env_id = {env_id!r}; classical controllers exist for {sorted(CONTROLLERS)}")
    return tuple(CONTROLLERS[env_id]())


def make_controller(env_id: str, name: str) -> Any:
    """A fresh classical controller ``name`` for ``env_id`` (tuned on the nominal plant)."""
    table = CONTROLLERS[env_id]() if env_id in CONTROLLERS else None
    if table is None:
        raise ValueError(f"env_id = {env_id!r}; classical controllers exist for {sorted(CONTROLLERS)}")
    if name not in table:
        raise ValueError(f"controller = {name!r} for {env_id}; allowed {sorted(table)}")
    return table[name]()
