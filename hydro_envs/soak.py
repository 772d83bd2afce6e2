r"""Soak test of the environments: long random rollouts at and beyond the randomisation extremes.

:func:`soak_env` drives one registered env's native vector env (the code path users and the
trainers run) with random actions -- i.i.d. uniform, held uniform levels and bang-bang
switching between -1 and +1 -- on parameter sets drawn at the *corners* of the randomisation
ranges (every randomised parameter at its low or high bound) and *beyond* them (corners of
the ranges widened by ``factor`` about their centre, :meth:`RandomizationSpec.widened`, clipped
into each field's physically allowed interval; a draw that is not a valid parameter set is
replaced by an in-range corner). Draws are passed as the benchmark passes frozen draws:
``reset(options={"reset_mask": copy i, "params": draw})``. It counts, per env:

``nonfinite``
    steps (per copy) with a NaN/inf in the plant state, the observation or the reward.
``pressure``
    steps with a guard breached at an env-step boundary: a hydraulic pressure below the
    cavitation floor ``pressure_floor`` (the guard clamps the state after every RK4 sub-step,
    so any value below the floor is a guard bug); pneumatic chambers: pressure below its
    floor or not > 0, air mass below its floor or not > 0, temperature ``T = p V / (m R)``
    not > 0.
``stroke``
    steps with a position outside its stroke by more than the end-stop tolerance. A body of
    mass ``M`` that reaches the Hunt-Crossley stop (stiffness ``k``) at speed ``v`` while a
    force ``F`` pushes it in penetrates ``delta <= F/k + sqrt((F/k)^2 + M v^2/k) <= 2 F/k +
    v sqrt(M/k)`` (energy: the stop's damping and the friction only remove energy). With
    ``v`` and ``F`` the running maxima (since the episode start) of the body's speed and of the
    force that can push it into the stop, the tolerance is twice that bound (a factor 2 for
    peaks between env-step samples). Bodies: servo piston, table, rodless slider, LS actuator,
    LS flow-compensator spool, LS control piston, force-actuator extension ``x_p + x_s``.
``energy``
    windows of ``ENERGY_WINDOW`` env steps (per copy) in which the bodies gained more
    mechanical energy than the ports delivered (below).
``passivity``
    RK4 sub-steps with a stage at which a dissipative element delivers power (below).
``replay``
    steps at which the instrumented re-integration did not reproduce the env's state bit for
    bit (then the energy check would not be about the env's trajectory).
``relief``
    steps (per copy) with a chamber pressure above what its relief valve holds it to: the
    plant model's ``relief_bounds(P)`` gives the chamber states and, per copy, the pressure at
    which each chamber's relief passes its rated flow (cracking + override; the supply where a
    relief is set below it, as the valve then feeds the chamber through it); a pressure above
    that bound times ``1 + RELIEF_TOL`` is a breach (a relief passing more than its rated flow,
    a chamber without relief on its path, or a relief that does not act). The largest ratio
    pressure / bound and the largest pressure are reported (``max_pressure_ratio``,
    ``max_pressure``).
``temperature``
    steps (per copy) with a pneumatic chamber (the model's ``soak_temperatures(Y, P)``) colder
    than ``MIN_TEMPERATURE`` = 250 K or than the physics allows (its
    ``soak_temperature_floor(P)``, an isentropic expansion from the wall temperature and the
    highest pressure to the exhaust: heat from the walls only warms the gas). Also reported: the
    coldest temperature (``min_temperature``) and the steps below 250 K (``cold_steps``). The
    cylinder walls alone (h = 50 W/(m^2 K)) let a chamber vented from the widened (beyond) supply
    pressures of 8-9.5 bar cool to 162-175 K; with the tube to the valve in the heat exchange (its
    inner wall at the tube-flow coefficient of the chamber's mass flow, the rodless model's
    ``chamber_wall_heat_flow``) the coldest was 265 K (measured, bench/soak.py).
``guard_clamps``
    how often a guard clamped the state (pressure floor, friction bound): reported, not a
    breach -- clamping at the cavitation floor is the guard doing its job under bang-bang
    valve reversals.

Energy balance (the exact inequality checked)
---------------------------------------------
For every plant the moving bodies have a mechanical energy ``E(y)`` = kinetic energy + spring
and end-stop potentials (``k delta^2/2`` of the stop's elastic part) + potential of constant
loads, and the forces on them split into *ports* whose power ``P_in(y)`` is not sign-definite
(the hydraulic/pneumatic pressure forces, the servo-valve-driven fluid force of the force
actuator, solenoid and flow forces, friction models with internal state: LuGre, Dahl) and
*dissipative elements* whose power ``D(y)`` is >= 0 by construction (memoryless Stribeck
friction with tanh sign, viscous dampers, the damping part of the Hunt-Crossley stops, which
is clipped so the stop never pulls). Along the exact solution ``dE/dt = P_in - D``.

After every env step, the plant's ``energy.energy_replay`` re-integrates each copy from its
state before the step with the same RK4 sub-steps and guards as the env's kernel (and checks
that it lands on the env's state bit for bit), integrating ``W = int P_in dt`` and
``Q = int D dt`` with the RK4 weights on the same stages (:mod:`hydro_envs.sim.balance`).
Each plant's ``energy.py`` says what its bodies, ports and dissipative elements are.
Two checks:

* **passivity** (exact, pointwise): ``D >= 0`` at every RK4 stage (relative round-off
  ``1e-12``); fails if a friction/damper/stop law pushes the body (e.g. a negative friction
  level or a pulling stop).
* **no energy created**, over windows of ``ENERGY_WINDOW`` = 20 env steps (and the last,
  shorter window of an episode): the mechanical energy gained cannot exceed the work the
  ports delivered, ``E(y_end) - E(y_start) <= sum W + tol`` with
  ``tol = ENERGY_RTOL * sum int(|P_in| + D) dt + ENERGY_ETOL * max |E| + 1e-12 J``,
  ``ENERGY_RTOL = 1e-3``, ``ENERGY_ETOL = 1e-7``. The dissipation is >= 0 by the first check;
  its stage quadrature is reported but not used. Why a window and not every step: near
  v = 0 the friction regularisation (and the stop damping) is integrated at ``h |lambda|``
  up to 2.2 (RK4 stable, not accurate) and the Hunt-Crossley force has a kink at contact
  onset, so a *single* step can show the mass gaining more than the port work (measured at
  the corners and beyond: up to 12 % of that step's turnover at a stop, 5 % in stick-slip);
  these local errors are bounded and are paid back by the friction within a few steps --
  over 20-step windows, in 1e7 steps per env at the corners and beyond (``bench/soak.py``),
  the largest gain was 0.59 of this tolerance (servo cylinder; below 1e-4 for the table,
  force actuator, LS and rodless cylinder), and a piston resting on a stop at full thrust
  gains at most ~5e-9 of the 0.58 J in the stop spring. An instability does not pay
  back: a mode integrated outside RK4's stability region grows by ``|R(h lambda)| > 1`` per
  sub-step (``R(-3) = 1.375``: its energy doubles every sub-step). It also fails on a sign
  error in a force or a port/energy mismatch. It is one-sided because the guards (pressure
  floor, friction bound) only remove energy.

What this check does *not* see: energy created on the fluid side (e.g. an unstable oil-spring
mode) enters the mechanical side as port work ``A (p1 - p2) v`` and balances; such a
blow-up shows up in the ``nonfinite``, ``pressure`` or ``stroke`` counts instead.

Cost: the replay doubles the kernel work; the Python loop around it dominates for small
batches.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any, Callable

import gymnasium as gym
import numpy as np

from hydro_envs import registry
from hydro_envs.contract import PlantModel
from hydro_envs.params import ParameterError

__all__ = [
    "SOAK_ENVS",
    "BREACH_KINDS",
    "ENERGY_RTOL",
    "ENERGY_ETOL",
    "RELIEF_TOL",
    "MIN_TEMPERATURE",
    "SoakResult",
    "energy_excess",
    "extreme_draw",
    "soak_env",
    "format_table",
]

#: one environment per plant that has envs (its first registry entry; the plant's other
#: tasks step the same kernel with other references)
SOAK_ENVS = tuple(spec.envs[0].id for spec in registry.specs() if spec.envs)
BREACH_KINDS = ("nonfinite", "pressure", "stroke", "energy", "passivity", "replay", "relief", "temperature")
#: a chamber may exceed its relief's full-flow pressure (cracking + override) by this fraction
#: of it (the override of a relief passing a little more than its rated flow; RK4 on its kinks)
RELIEF_TOL = 0.02
#: the coldest pneumatic chamber temperature [K] the soak accepts
MIN_TEMPERATURE = 250.0
#: energy tolerance relative to the window's power turnover int(|P_in| + D) dt
ENERGY_RTOL = 1e-3
#: energy tolerance relative to the largest stored mechanical energy in the window
ENERGY_ETOL = 1e-7
#: env steps per energy-balance window
ENERGY_WINDOW = 20
#: draws needing more RK4 sub-steps per env step than this are not used (cost)
MAX_SUBSTEPS = 400


def energy_excess(e_start, e_end, work, turnover, scale):
    """Energy gained over a window beyond the port work, in units of the tolerance
    (> 1: a violation): ``(E_end - E_start - W) / (ENERGY_RTOL turnover + ENERGY_ETOL scale
    + 1e-12 J)`` with ``scale`` the largest |E| in the window (arrays or floats)."""
    return (e_end - e_start - work) / (ENERGY_RTOL * turnover + ENERGY_ETOL * scale + 1e-12)


# ============================================================================ draws
def _clip_to_allowed(params_cls: type, name: str, value: float) -> float:
    """``value`` moved into the field's allowed interval (open ends: just inside)."""
    meta = params_cls.__dataclass_fields__[name].metadata
    lo, hi = meta["allowed"]
    if value < lo or (meta["open_low"] and value <= lo):
        value = np.nextafter(lo, np.inf) if meta["open_low"] else lo
    if value > hi or (meta["open_high"] and value >= hi):
        value = np.nextafter(hi, -np.inf) if meta["open_high"] else hi
    return float(value)


def extreme_draw(batch: Any, rng: np.random.Generator, beyond: bool, factor: float) -> tuple[dict[str, float], str]:
    """One parameter draw at a random corner of the randomisation ranges, or (``beyond``) of
    the ranges widened by ``factor`` and clipped into the allowed intervals. Returns the
    values of the randomised parameters and the kind actually drawn (``corner``,
    ``beyond``; a beyond draw that stays invalid after 20 attempts falls back to a corner)."""
    spec, base = batch.spec, batch.base_params
    n = len(spec.entries)
    wide = spec.widened(factor) if beyond else spec
    for _ in range(20 if beyond else 1):
        flags = rng.integers(0, 2, n).astype(bool)
        values = {}
        for e, hi in zip(wide.entries, flags):
            lo_v, hi_v = e.value_range(getattr(base, e.name))
            values[e.name] = _clip_to_allowed(batch.params_cls, e.name, hi_v if hi else lo_v)
        try:
            p = batch.params_cls.from_mapping(values, base=base)
            if batch.substeps_for(p) > MAX_SUBSTEPS:
                continue
        except (ParameterError, ValueError, ZeroDivisionError, OverflowError):
            continue
        return values, ("beyond" if beyond else "corner")
    return extreme_draw(batch, rng, False, factor)


# ============================================================================ driver
@dataclasses.dataclass
class SoakResult:
    env_id: str
    steps: int  # env steps summed over copies
    seconds: float
    draws: dict[str, int]  # number of episodes per draw kind
    counts: dict[str, int]  # breach kind -> count (steps or stages)
    guard_clamps: int
    max_energy_excess: float  # largest (E1 - E0 - W + Q) / tol seen (< 1 passes)
    examples: dict[str, dict[str, Any]]  # first occurrence of every breach kind (energy: the worst)
    max_pressure_ratio: float = float("nan")  # largest chamber pressure / its relief bound (nan: no relief)
    max_pressure: float = float("nan")  # largest chamber pressure [Pa] among the relief-bounded states
    min_temperature: float = float("nan")  # coldest pneumatic chamber [K] (nan: no pneumatic chamber)
    cold_steps: int = 0  # steps (per copy) with a pneumatic chamber below MIN_TEMPERATURE (reported)

    @property
    def steps_per_second(self) -> float:
        return self.steps / self.seconds if self.seconds > 0 else float("nan")

    @property
    def breaches(self) -> int:
        return int(sum(self.counts.values()))


def _actions(rng, mode, level, hold, adim, mean_hold):
    """Next actions ``(n, adim)``: mode 0 i.i.d. uniform, 1 held uniform levels, 2 bang-bang
    (+-1 held for geometric dwell times, switching sign)."""
    hold -= 1
    new = hold <= 0
    if new.any():
        k = int(new.sum())
        bang = mode[new] == 2
        lv = rng.uniform(-1.0, 1.0, (k, adim))
        flip = -np.sign(level[new])
        flip[flip == 0] = 1.0
        lv[bang] = flip[bang]
        level[new] = lv
        hold[new] = rng.geometric(1.0 / mean_hold[new])
    a = level.copy()
    iid = mode == 0
    if iid.any():
        a[iid] = rng.uniform(-1.0, 1.0, (int(iid.sum()), adim))
    return a


class _LimitTracker:
    """The physical bounds of a plant's chambers, checked after every env step: pressures below
    their relief valves' full-flow pressure (the contract's ``relief_bounds(P) -> (state indices,
    (n, k) bounds [Pa])``), pneumatic temperatures (the model's ``soak_temperatures(Y, P) ->
    (n, k) [K]``) above :data:`MIN_TEMPERATURE` and its ``soak_temperature_floor(P)`` (the steps
    below MIN_TEMPERATURE also counted apart); a plant without them has no such breach."""

    def __init__(self, model: PlantModel) -> None:
        self.relief = model.relief_bounds
        self.temperatures = model.soak_temperatures
        self.floor = model.soak_temperature_floor
        self.max_ratio = self.max_pressure = self.min_temperature = float("nan")
        self.cold_steps = 0

    def breaches(self, Y: np.ndarray, P: np.ndarray) -> dict[str, np.ndarray]:
        n = Y.shape[0]
        out = {"relief": np.zeros(n, dtype=bool), "temperature": np.zeros(n, dtype=bool)}
        if self.relief is not None:
            idx, bound = self.relief(P)
            pr = Y[:, list(idx)]
            ratio = pr / bound
            out["relief"] = np.any(ratio > 1.0 + RELIEF_TOL, axis=1)
            if np.isfinite(ratio).any():
                self.max_ratio = float(np.fmax(self.max_ratio, np.nanmax(ratio)))
                self.max_pressure = float(np.fmax(self.max_pressure, np.nanmax(pr)))
        if self.temperatures is not None and self.floor is not None:
            t = self.temperatures(Y, P)
            bound = np.maximum(self.floor(P), MIN_TEMPERATURE)
            out["temperature"] = np.any(~(t >= bound[:, None]), axis=1)
            self.cold_steps += int(np.any(t < MIN_TEMPERATURE, axis=1).sum())
            if np.isfinite(t).any():
                self.min_temperature = float(np.fmin(self.min_temperature, np.nanmin(t)))
        return out


def soak_env(
    env_id: str,
    steps: int,
    *,
    num_envs: int = 64,
    seed: int = 0,
    factor: float = 2.0,
    beyond_fraction: float = 0.5,
    bang_fraction: float = 0.4,
    episode_steps: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> SoakResult:
    """Run ``steps`` env steps (summed over ``num_envs`` copies, rounded up to whole batch
    steps) of ``env_id``'s native vector env; see the module docstring for what is counted."""
    if steps < 1 or num_envs < 1:
        raise ValueError(f"steps and num_envs must be >= 1, got {steps}, {num_envs}")
    if not (math.isfinite(factor) and factor > 1.0):
        raise ValueError(f"factor must be > 1, got {factor}")
    kw: dict[str, Any] = {"num_envs": num_envs, "vectorization_mode": "vector_entry_point"}
    if episode_steps is not None:
        kw["max_episode_steps"] = int(episode_steps)
    venv = gym.make_vec(env_id, **kw)
    b = venv.unwrapped._batch if hasattr(venv, "unwrapped") else venv._batch
    b.check_finite = False  # a non-finite copy is counted here (a breach), not raised
    energy = b.plant_spec.module("energy")
    n, adim = b.n, b.action_dim
    rng = np.random.default_rng([seed, 8])
    counts = {k: 0 for k in BREACH_KINDS}
    examples: dict[str, dict[str, Any]] = {}
    draws = {"corner": 0, "beyond": 0}
    current: list[dict[str, float]] = [{} for _ in range(n)]
    RUN = np.zeros((n, 2 * energy.N_BODIES))
    flags = np.zeros((n, 2), dtype=np.int64)
    Y0 = np.empty_like(b.Y)
    Yend = np.empty_like(b.Y)
    W2 = np.zeros_like(b.W)
    out = np.zeros((n, 7))
    mode = np.zeros(n, dtype=np.int64)
    level = np.zeros((n, adim))
    hold = np.zeros(n, dtype=np.int64)
    mean_hold = np.ones(n)
    max_excess = 0.0
    limits = _LimitTracker(b.plant_spec.contract)
    # energy-balance windows (see ENERGY_WINDOW): start energy and state, sums over the window
    win_e0 = np.zeros(n)
    win_y0 = np.zeros_like(b.Y)
    win_w = np.zeros(n)
    win_t = np.zeros(n)
    win_scale = np.zeros(n)
    win_contact = np.zeros(n, dtype=bool)
    win_len = 0
    clamps_total = 0

    def new_episodes() -> None:
        nonlocal clamps_total, win_len
        clamps_total += int(b.clamps.sum())
        for i in range(n):
            beyond = bool(rng.random() < beyond_fraction)
            values, kind = extreme_draw(b, rng, beyond, factor)
            draws[kind] += 1
            current[i] = values
            mask = np.zeros(n, dtype=bool)
            mask[i] = True
            # no seed: copy i continues its own stream (seeded seed + i by the first reset)
            venv.reset(options={"reset_mask": mask, "params": values})
        RUN[:] = 0.0
        win_len = 0
        u = rng.random(n)
        mode[:] = np.where(u < bang_fraction, 2, np.where(u < bang_fraction + 0.5 * (1 - bang_fraction), 1, 0))
        hold[:] = 0
        level[:] = 0.0
        mean_hold[:] = np.where(mode == 2, 100.0, 20.0) * rng.uniform(0.5, 2.0, n)

    def record(kind: str, i: int, k: int, extra: dict[str, Any] | None = None) -> None:
        """Keep the first breach of each kind; for ``energy`` the worst one."""
        worse = kind == "energy" and kind in examples and extra["excess"] > examples[kind]["excess"]
        if kind not in examples or worse:
            examples[kind] = {
                "step": k,
                "copy": i,
                "episode_step": int(b.K[i]),
                "params": dict(current[i]),
                "state": b.state_dict(i),
                "state_before": dict(zip(b.plant.STATE_NAMES, Y0[i].tolist())),
                **(extra or {}),
            }

    venv.reset(seed=int(seed))
    new_episodes()
    batch_steps = -(-int(steps) // n)
    t0 = time.perf_counter()
    for k in range(batch_steps):
        a = _actions(rng, mode, level, hold, adim, mean_hold)
        Y0[:] = b.Y
        obs, reward, _, truncated, _ = venv.step(a)
        # energy replay of this step (same U, P, NSUB as the env's kernel call)
        energy.energy_replay(Y0, b.U, b.P, b.dt, b.NSUB, W2, Yend, out)
        same = (Yend == b.Y) | (np.isnan(Yend) & np.isnan(b.Y))
        bad_replay = ~np.all(same, axis=1)
        fin = np.all(np.isfinite(b.Y), axis=1) & np.all(np.isfinite(obs), axis=1) & np.isfinite(reward)
        energy.state_breaches(b.Y, b.P, RUN, flags)
        if win_len == 0:
            win_e0[:] = out[:, 0]
            win_y0[:] = Y0
            win_w[:] = 0.0
            win_t[:] = 0.0
            win_scale[:] = np.abs(out[:, 0])
            win_contact[:] = False
        win_len += 1
        win_w += out[:, 2]
        win_t += out[:, 4]
        np.maximum(win_scale, np.abs(out[:, 1]), out=win_scale)
        win_contact |= out[:, 6] > 0
        bad_energy = np.zeros(n, dtype=bool)
        excess = np.zeros(n)
        if win_len == ENERGY_WINDOW or truncated.any():
            excess = energy_excess(win_e0, out[:, 1], win_w, win_t, win_scale)
            fin_e = np.isfinite(excess)
            if fin_e.any():
                max_excess = max(max_excess, float(excess[fin_e].max()))
            bad_energy = fin_e & (excess > 1.0)
            win_len = 0
        per_kind = {
            "nonfinite": ~fin,
            "pressure": flags[:, 0] > 0,
            "stroke": flags[:, 1] > 0,
            "energy": bad_energy,
            "passivity": out[:, 5] > 0,
            "replay": bad_replay,
            **limits.breaches(b.Y, b.P),
        }
        for kind, mask in per_kind.items():
            if mask.any():
                counts[kind] += int(out[mask, 5].sum()) if kind == "passivity" else int(mask.sum())
                idx = np.flatnonzero(mask)
                i = int(idx[np.argmax(excess[idx])]) if kind == "energy" else int(idx[0])
                extra = {"excess": float(excess[i])}
                if kind == "energy":
                    extra.update(window_start_state=dict(zip(b.plant.STATE_NAMES, win_y0[i].tolist())),
                                 window_energy=[float(win_e0[i]), float(out[i, 1]), float(win_w[i]), float(win_t[i])],
                                 window_contact=bool(win_contact[i]))
                record(kind, i, k, extra)
        if truncated.any():
            new_episodes()
        if progress is not None and (k + 1) % max(1, batch_steps // 10) == 0:
            progress(f"{env_id}: {(k + 1) * n} steps, {sum(counts.values())} breaches")
    seconds = time.perf_counter() - t0
    clamps_total += int(b.clamps.sum())
    venv.close()
    return SoakResult(env_id, batch_steps * n, seconds, draws, counts, clamps_total, max_excess, examples,
                      limits.max_ratio, limits.max_pressure, limits.min_temperature, limits.cold_steps)


def format_table(results: list[SoakResult]) -> str:
    """Markdown table: env, steps, steps/s, each breach count, guard clamps, draws."""
    head = ["env", "steps", "steps/s", *BREACH_KINDS, "guard_clamps", "max E excess/tol", "max p/relief",
            "max p [bar]", "min T [K]", "steps < 250 K", "draws corner/beyond"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        cells = [r.env_id, f"{r.steps:,}", f"{r.steps_per_second:,.0f}", *(str(r.counts[k]) for k in BREACH_KINDS),
                 str(r.guard_clamps), f"{r.max_energy_excess:.3g}", f"{r.max_pressure_ratio:.3f}",
                 f"{r.max_pressure / 1e5:.1f}", f"{r.min_temperature:.1f}", str(r.cold_steps),
                 f"{r.draws['corner']}/{r.draws['beyond']}"]
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)
