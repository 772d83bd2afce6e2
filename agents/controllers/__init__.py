"""Classical controllers for every hydro_envs environment.

All are policy objects with the SB3-style ``predict(obs, state=None, episode_start=None,
deterministic=True) -> (action, state)`` for a single observation or a batch, tuned on the
*nominal* plant from its linearisation (rules and numbers in each module's docstring).

One module per plant, named after it (``agents.controllers.<plant>``), declares its
controllers (``controllers()``: name -> factory), what the benchmark reads of its envs
(``benchmark_adapter(env_id)``) and, where the plant has friction feed-forward, its virtual
friction experiment (``friction_points()``). Every env id the plant registry lists for a plant
gets that plant's controllers: ``zero``/``passive``, ``pid``, and where identified friction
applies ``pid_ff_stribeck`` / ``pid_ff_neural`` (models from virtual constant-velocity
experiments, :mod:`agents.controllers.friction_models`), ``flow`` (flow feedback
linearisation through the inverse orifice law) and ``p``. :func:`make_controller` builds one by
env id and name.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from types import ModuleType
from typing import Any

from agents.controllers.core import BaseController, PIDCore, ZeroController

__all__ = [
    "CONTROLLERS",
    "BaseController",
    "PIDCore",
    "ZeroController",
    "controller_module",
    "controller_names",
    "make_controller",
]


def controller_module(plant: str) -> ModuleType | None:
    """``agents.controllers.<plant>``, or None if the plant has no classical controllers."""
    try:
        return importlib.import_module(f"agents.controllers.{plant}")
    except ModuleNotFoundError as e:
        if e.name != f"agents.controllers.{plant}":
            raise
        return None


def _discover() -> dict[str, Callable[[], dict[str, Callable[[], Any]]]]:
    from hydro_envs import registry

    out: dict[str, Callable[[], dict[str, Callable[[], Any]]]] = {}
    for spec in registry.specs():
        mod = controller_module(spec.name) if spec.envs else None
        if mod is not None:
            for env_id in spec.env_ids:
                out[env_id] = mod.controllers
    return out


#: env id -> function returning {controller name: zero-argument factory}
CONTROLLERS: dict[str, Callable[[], dict[str, Callable[[], Any]]]] = _discover()


def controller_names(env_id: str) -> tuple[str, ...]:
    """Classical controller names available for ``env_id``."""
    if env_id not in CONTROLLERS:
        raise ValueError(f"env_id = {env_id!r}; classical controllers exist for {sorted(CONTROLLERS)}")
    return tuple(CONTROLLERS[env_id]())


def make_controller(env_id: str, name: str, params: Any = None) -> Any:
    """A fresh classical controller ``name`` for ``env_id``, tuned on the nominal plant, or on
    ``params`` (a rig's parameters, e.g. from a parameter file) where the plant's
    ``controllers(params)`` takes them; ``ValueError`` where it does not."""
    if env_id not in CONTROLLERS:
        raise ValueError(f"env_id = {env_id!r}; classical controllers exist for {sorted(CONTROLLERS)}")
    if params is None:
        table = CONTROLLERS[env_id]()
    elif "params" in inspect.signature(CONTROLLERS[env_id]).parameters:
        table = CONTROLLERS[env_id](params)
    else:
        raise ValueError(f"the controllers of {env_id} are tuned on the seed rig only; they take no rig parameters")
    if name not in table:
        raise ValueError(f"controller = {name!r} for {env_id}; allowed {sorted(table)}")
    return table[name]()
