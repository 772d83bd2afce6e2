"""Every declared allowed range is one the plant steps finitely and in bounded time on
(issue 53 item 5): each parameter at each end of its allowed interval (just inside an open end),
the others nominal, makes its env and takes random-action steps with finite observations and
rewards. A value refused only because of another field (a cross-field constraint such as
``F_s >= F_c``) is allowed: its error names the other field."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs import registry
from hydro_envs.params import ParameterError

#: random-action steps per range end (the non-finite cases this guards against diverge in < 120)
STEPS = 150
#: range ends the plant steps on but an env refuses by name, with the reason
ENV_REFUSALS = {
    ("shaking_table", "flow_coefficient", "low"): "a sealed valve (the plant's physics tests) moves no table",
    ("force_actuator", "supply_pressure", "low"): "the small-force task's +-60 N do not fit a 1 bar actuator",
}
#: envs whose rig differs from their plant's first env (another parameter set): in the default suite
OWN_RIG = ("hydro_envs/ForceActuatorSmallForce-v0",)


def _env_of(plant: str) -> str:
    return next(e.id for s, e in registry.env_entries() if s.name == plant)


def _ends(params_cls: type) -> list[tuple[str, str, float]]:
    out = []
    for f in params_cls.__dataclass_fields__.values():
        m = f.metadata
        if "allowed" not in m:
            continue
        lo, hi = m["allowed"]
        if m["open_low"]:
            lo = float(np.nextafter(lo, np.inf)) if lo != 0.0 else 1e-12
        if m["open_high"]:
            hi = float(np.nextafter(hi, -np.inf))
        out += [(f.name, "low", lo), (f.name, "high", hi)]
    return [(n, e, v) for n, e, v in out if math.isfinite(v)]


def _cases():
    plants = sorted({s.name for s, _ in registry.env_entries()})
    return [pytest.param(p, id=p) for p in plants]


def _step_at(env_id: str, name: str, value: float, by_name: bool = False) -> str:
    """``""`` when the env steps finitely (or, ``by_name``, refuses the value naming it), else
    what went wrong."""
    try:
        env = gym.make(env_id, randomize=False, params={name: value})
    except ParameterError as exc:
        if by_name and f"{name} = " in str(exc):
            return ""
        others = str(exc).replace(name, "")
        return "" if any(f in others for f in env_fields(env_id) if f != name) else f"refused: {exc}"
    except Exception as exc:  # noqa: BLE001 - every other error is a finding
        return f"{type(exc).__name__}: {exc}"
    rng = np.random.default_rng(0)
    try:
        env.reset(seed=0)
        for k in range(STEPS):
            obs, reward, term, trunc, _ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
            if not (np.all(np.isfinite(obs)) and np.isfinite(reward)):
                return f"non-finite observation at step {k}"
            if term or trunc:
                env.reset(seed=k)
    except Exception as exc:  # noqa: BLE001
        if by_name and isinstance(exc, ParameterError) and f"{name} = " in str(exc):
            return ""
        return f"{type(exc).__name__}: {str(exc)[:200]}"
    finally:
        env.close()
    return ""


def env_fields(env_id: str) -> tuple[str, ...]:
    return tuple(registry.spec_for_env(env_id).params_cls.__dataclass_fields__)


def _task_envs():
    firsts = {_env_of(p) for p in {s.name for s, _ in registry.env_entries()}}
    return [pytest.param(s.name, e.id, id=e.id.split("/")[-1],
                         marks=() if e.id in OWN_RIG else pytest.mark.slow)
            for s, e in registry.env_entries() if e.id not in firsts]


@pytest.mark.parametrize("plant", _cases())
def test_every_range_end_steps_finitely(plant):
    _check_range_ends(plant, _env_of(plant))


@pytest.mark.parametrize("plant, env_id", _task_envs())
def test_every_range_end_steps_finitely_on_the_task_envs(plant, env_id):
    _check_range_ends(plant, env_id)


def _check_range_ends(plant: str, env_id: str) -> None:
    bad = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, end, value in _ends(registry.get(plant).params_cls):
            why = _step_at(env_id, name, value, by_name=(plant, name, end) in ENV_REFUSALS)
            if why:
                bad.append(f"{name} = {value:g} ({end} end): {why}")
    assert not bad, f"{env_id}: range ends the plant does not step on:\n" + "\n".join(bad)
