r"""Virtual experiments of seed 001 on the force actuator: the static tests and the PRBS record.

Source: ``001_3253c61f41166c3e.txt`` sec. 4.2 (open-loop static force characteristic) and
sec. 4.4 (measurement of the hydraulic damping effect, eq (5)); plant
:mod:`hydro_envs.plants.force_actuator`.

1. :func:`blocked_force_test` -- "With the piston locked to the mount, the open-loop static
   force characteristic was recorded while the valve current was slowly varied [...]
   following a triangular input." ``piston_locked = 1`` is enforced; the current goes
   ``0 -> i_min`` (initialising the hysteresis on the major loop), ``i_min -> i_max`` (up
   branch), ``i_max -> i_min`` (down branch), each full leg in ``ramp_time`` seconds, held
   at every 0.2 ms sample (5 kHz, ``SEED_T``) and simulated with
   :func:`hydro_envs.sim.simulate`. The sensed force ``k_s x_s`` is
   recorded (+ optional white noise). :func:`quasi_static_force` is the analytic reference:
   the plant's Prandtl-Ishlinskii plays driven by the current sequence (exact for a
   quasi-static input), the DC gain of the valve G(s), and the orifice-law solve
   :func:`~hydro_envs.plants.force_actuator.static_force` with the valve offset.
   :func:`branch_current_offset` measures the horizontal distance of the two branches.

   Not in the reference: the seal friction. With the piston locked the sensor deflection
   still slides the seals (the relative velocity is ``x_s'``), so the Dahl pre-sliding
   spring (``friction_stiffness``, in parallel with ``k_s``) takes up to the stiction level
   (54 N while the force rises, 99 N while it falls): the nominal characteristic sits
   ~54 N below / ~99 N above the friction-free curve, which widens the loop (001 sec. 3.3
   "Friction is also included in the static force characteristic but we neglected it").

2. :func:`hanging_mass_test` -- "the actuator was mounted vertically such that weights could
   be hung from the piston (which was free to move) [...] for the same input current,
   different masses were hung to the piston and the corresponding steady-state velocities
   were measured [...] the total force applied on the piston could be calculated as the
   sum of the measured hydraulic force and the gravitational force [...] we neglected the
   friction force." For every (current, mass): the piston is first held locked
   (``settle_time``) so that the valve settles and the *blocked* force at that current is
   measured (the paper measured it in a separate locked run with the same current
   sequence); then it is released near the retracted stop and runs with the load until
   it approaches the far stop; the steady velocity is averaged over the last part of the
   free run. Points: ``force = F_blocked + m g`` against ``velocity``.

   **Load model.** The experiment sets ``load_mass = m`` (inertia of the hanging weight) and
   the plant's ``load_force = m g`` (positive = extending, the weight hangs below the rod);
   everything else is the plant's physics.

   At steady state (``v_p`` constant, ``x_s' = 0``, the 40 Hz filter settled, the Dahl
   state at its sliding level) the piston equation reads
   ``F~(xi) + m g = dg F_d(xi, v) + g(v) sgn(v)``: :func:`steady_force_balance_residual`.

3. :func:`prbs_locked` -- sec. 4.5: "With the piston fixed at midstroke position, a
   low-amplitude PRBS input was applied to the open-loop system"; sampled at 5000 Hz, the
   record from which eq (6)'s ARX model was identified.

Files: the plant registers only the channels ``i`` [A] and ``f`` [N]. The blocked test
writes exactly those. The hanging-mass file adds the extra columns ``v`` [m/s] (piston
velocity) and ``load`` [N] (``m g``), so it is written -- and must be loaded -- with
``allow_extra=True``; run boundaries are in the metadata.
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Any

import numpy as np

from hydro_envs.data.measured import write_measured
from hydro_envs.excitation import prbs
from hydro_envs.laws.hysteresis import pi_memories
from hydro_envs.plants.force_actuator import model as fa
from hydro_envs.plants.force_actuator.spec import SPEC as _SPEC
from hydro_envs.sim.simulate import simulate

__all__ = [
    "G",
    "valve_dc_gain",
    "triangular_current",
    "quasi_static_force",
    "blocked_force_test",
    "branch_current_offset",
    "hanging_mass_test",
    "steady_force_balance_residual",
    "prbs_locked",
    "breakaway_test",
    "breakaway_force",
    "open_loop_force_response",
]

G = 9.81  # m/s^2

#: DC gain of the continuous valve model G(s) = K (s + c) / ((s + a)(s + b)) (eq (7): 1.0003)
def valve_dc_gain() -> float:
    return fa.VALVE_K * fa.VALVE_C / (fa.VALVE_A * fa.VALVE_B)


# ====================================================================================
# blocked-piston static force characteristic (001 sec. 4.2)
# ====================================================================================
def triangular_current(i_min: float, i_max: float, ramp_time: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``0 -> i_min -> i_max -> i_min``, each full leg (``i_min <-> i_max``) in ``ramp_time``.

    Returns ``(i, branch)``: the held current per sample and ``branch`` = 0 on the
    initialising leg, +1 on the up leg, -1 on the down leg."""
    rate = (i_max - i_min) / ramp_time
    legs = [(0.0, i_min, 0), (i_min, i_max, 1), (i_max, i_min, -1)]
    cur, br = [], []
    for a, b, tag in legs:
        n = max(int(round(abs(b - a) / rate / dt)), 1)
        seg = a + (b - a) * np.arange(1, n + 1) / n
        cur.append(seg)
        br.append(np.full(n, tag, dtype=np.int64))
    return np.concatenate(cur), np.concatenate(br)


def quasi_static_force(params: fa.ForceActuatorParams, currents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Analytic quasi-static blocked force for the current sequence ``currents`` [A].

    Plays of the plant's hysteresis (demagnetised start) updated sample by sample (exact for a
    piecewise-monotone input), ``x_v = G(0) x~``, ``F = static_force(x_v + valve_offset)``
    (orifice-law solve, sec. 3.1). Friction is not included. Returns ``(force [N], xi)``."""
    p = params
    n = fa.N_PLAY
    w = (1.0 - p.hysteresis_reversal_slope) / n
    g0 = valve_dc_gain()
    a2 = p.bore_area - p.rod_area
    out = np.empty(len(currents))
    u_all = np.asarray(currents, dtype=float) / p.rated_current
    mem = pi_memories(u_all, p.hysteresis_width, p.hysteresis_reversal_slope, n)
    xt = p.hysteresis_reversal_slope * u_all
    for j in range(n):
        xt = xt + w * mem[:, j]
    xis = g0 * xt + p.valve_offset
    for k in range(len(xis)):
        out[k] = fa.static_force(xis[k], p.supply_pressure, p.bore_area, a2)
    return out, xis


def blocked_force_test(
    params: fa.ForceActuatorParams | None = None,
    *,
    currents: tuple[float, float] | None = None,
    ramp_time: float = 4.0,
    noise_std: float = 0.0,
    seed: int | None = 0,
    path: str | os.PathLike[str] | None = None,
) -> dict[str, Any]:
    """Blocked-piston static force test (001 sec. 4.2), see the module doc.

    ``currents``: ``(i_min, i_max)`` [A] of the triangle (default ``+-current_max``);
    ``ramp_time`` [s]: duration of one full leg; ``noise_std`` [N]: white noise on the
    sensed force; ``path``: write a measured-data file (plant ``force_actuator``, channels
    ``t, i, f``). Returns ``t, i, f, f_true, branch, xi`` (valve position + offset, truth),
    ``f_static`` (quasi-static reference, :func:`quasi_static_force`), ``clamps``, ``path``.
    """
    p = params if params is not None else fa.ForceActuatorParams()
    p = dataclasses.replace(p, piston_locked=1.0)
    if not (math.isfinite(ramp_time) and ramp_time > 0):
        raise ValueError(f"ramp_time must be > 0 s, got {ramp_time}")
    if noise_std < 0:
        raise ValueError(f"noise_std must be >= 0, got {noise_std}")
    i_min, i_max = (-p.current_max, p.current_max) if currents is None else map(float, currents)
    if not i_min < 0.0 < i_max:
        raise ValueError(f"currents must satisfy i_min < 0 < i_max, got ({i_min}, {i_max})")
    dt = fa.SEED_T
    i, branch = triangular_current(i_min, i_max, ramp_time, dt)
    clamps = np.zeros(1, dtype=np.int64)
    states = simulate(_SPEC, p, i.reshape(-1, 1), fa.rest_state(p), dt, clamps=clamps)[1:]
    f = p.sensor_stiffness * states[:, fa.XS]
    xi = _valve_positions(states, p)
    t = dt * np.arange(1, i.size + 1)
    rng = np.random.default_rng(seed)
    f_meas = f + (noise_std * rng.standard_normal(f.size) if noise_std > 0 else 0.0)
    f_static, _ = quasi_static_force(p, i)
    out_path = None
    if path is not None:
        out_path = write_measured(
            path, t, {"i": i, "f": f_meas}, plant=fa.PLANT,
            metadata={"experiment": "blocked_force_test (001 sec. 4.2)", "ramp_time_s": ramp_time,
                      "i_min_A": i_min, "i_max_A": i_max, "noise_std_N": noise_std,
                      "piston_locked": 1, "branches": "0->i_min, i_min->i_max (up), i_max->i_min (down)"},
        )
    return {"t": t, "i": i, "f": f_meas, "f_true": f, "branch": branch, "xi": xi,
            "f_static": f_static, "clamps": int(clamps[0]), "path": out_path}


def _valve_positions(states: np.ndarray, p: fa.ForceActuatorParams) -> np.ndarray:
    """``xi`` (valve position + offset) of recorded states: after each step the guard has set
    every play to its output for the current coil state, so ``x~ = w0 ic + w sum h_k`` exactly."""
    hs = states[:, fa.H0:fa.H0 + fa.N_PLAY].sum(axis=1)
    xt = p.hysteresis_reversal_slope * states[:, fa.IC] + (1.0 - p.hysteresis_reversal_slope) / fa.N_PLAY * hs
    return fa.VALVE_K / fa.VALVE_A * (xt + (fa.VALVE_C - fa.VALVE_B) * states[:, fa.GW]) + p.valve_offset


def branch_current_offset(i: np.ndarray, f: np.ndarray, branch: np.ndarray,
                          levels: np.ndarray) -> np.ndarray:
    """Current difference ``i_up(F) - i_down(F)`` [A] of the two branches at force ``levels``.

    Each branch is made monotone (running max / min of the force) before inverting by
    linear interpolation; levels outside a branch's range give NaN."""
    out = np.full(len(levels), np.nan)
    up = branch == 1
    dn = branch == -1
    fu = np.maximum.accumulate(f[up])
    iu = i[up]
    fd = np.minimum.accumulate(f[dn])[::-1]
    idn = i[dn][::-1]
    for k, lev in enumerate(levels):
        if fu[0] < lev < fu[-1] and fd[0] < lev < fd[-1]:
            ju = np.searchsorted(fu, lev)
            jd = np.searchsorted(fd, lev)
            # first crossing on each (monotone) branch
            a_u = (lev - fu[ju - 1]) / (fu[ju] - fu[ju - 1]) if fu[ju] > fu[ju - 1] else 0.0
            a_d = (lev - fd[jd - 1]) / (fd[jd] - fd[jd - 1]) if fd[jd] > fd[jd - 1] else 0.0
            out[k] = (iu[ju - 1] + a_u * (iu[ju] - iu[ju - 1])) - (idn[jd - 1] + a_d * (idn[jd] - idn[jd - 1]))
    return out


# ====================================================================================
# hanging-mass damping test (001 sec. 4.4, eq (5))
# ====================================================================================
def _run_loaded(y: np.ndarray, current: float, p: fa.ForceActuatorParams, dt: float, n_steps: int,
                q_stop: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``n_steps`` samples at the held ``current`` from state ``y`` (the plant's ``load_force``
    acts on a free piston); stops after the first sample whose extension ``x_p + x_s`` passes
    ``q_stop``. Returns the relative velocity, sensed force and ``xi`` per sample and the
    last state."""
    states = simulate(_SPEC, p, np.full((n_steps, 1), current), y, dt)[1:]
    past = np.flatnonzero(states[:, fa.XP] + states[:, fa.XS] > q_stop)
    if past.size:
        states = states[: past[0] + 1]
    return (states[:, fa.VP] + states[:, fa.VS], p.sensor_stiffness * states[:, fa.XS],
            _valve_positions(states, p), states[-1].copy())


def steady_force_balance_residual(params: fa.ForceActuatorParams, xi: float, v: float, load: float) -> float:
    """``F~(xi) + load - dg F_d(xi, v) - g(v) sgn(v)`` [N]: zero at a steady free-piston run
    (no load spring: ``load_stiffness`` must be 0)."""
    p = params
    f_st = fa.static_force(xi, p.supply_pressure, p.bore_area, p.bore_area - p.rod_area)
    f_d = p.damping_gain * fa.hydraulic_damping(xi, v, p.damping_force_scale, p.damping_knee_velocity,
                                                p.damping_sharpness, p.damping_linear)
    g = fa.stiction_level(v, p.coulomb_friction, p.stiction_retract, p.stiction_extend, p.stribeck_velocity)
    return float(f_st + load - f_d - g * math.copysign(1.0, v))


def hanging_mass_test(
    params: fa.ForceActuatorParams | None = None,
    *,
    masses: tuple[float, ...] = (0.0, 2.0, 5.0, 10.0),
    currents: tuple[float, ...] = (0.005, 0.010, 0.015),
    duration: float = 0.5,
    settle_time: float = 0.1,
    window_fraction: float = 0.3,
    noise_std: float = 0.0,
    seed: int | None = 0,
    path: str | os.PathLike[str] | None = None,
) -> dict[str, Any]:
    """Hanging-mass damping test (001 sec. 4.4), see the module doc.

    For each current [A] (outer loop, the paper's order) and mass [kg]: ``settle_time``
    locked (blocked force measured as the mean sensed force over its last 20 %), then up to
    ``duration`` free with load ``m g`` from 1 mm extension until 3 mm before the far stop.
    The steady velocity is the mean over the last ``window_fraction`` of the free run
    (at least 10 ms); ``steady`` flags runs whose velocity in that window varies by less
    than 2 % (or 1 mm/s). ``noise_std`` [N] is added to the sensed force in the file only.

    Returns per point (arrays, shape ``(n_currents * n_masses,)``): ``current, mass,
    load`` (= m g), ``f_blocked`` (measured blocked force), ``force`` (= f_blocked + m g,
    the paper's total force), ``velocity``, ``velocity_std``, ``xi`` (truth at the window's
    end), ``steady``; and ``path``.
    """
    p0 = params if params is not None else fa.ForceActuatorParams()
    if p0.load_stiffness != 0.0:
        raise ValueError("hanging_mass_test needs load_stiffness = 0 (a pure weight load)")
    if not (duration > 0 and settle_time > 0 and 0 < window_fraction < 1):
        raise ValueError("duration, settle_time > 0 and 0 < window_fraction < 1 required")
    dt = fa.SEED_T
    n_settle = int(round(settle_time / dt))
    n_free = int(round(duration / dt))
    rng = np.random.default_rng(seed)
    rows: dict[str, list] = {k: [] for k in ("current", "mass", "load", "f_blocked", "force", "velocity",
                                             "velocity_std", "xi", "steady", "free_time")}
    t_all, i_all, f_all, v_all, l_all = [], [], [], [], []
    t0 = 0.0
    runs = []
    for cur in currents:
        for m in masses:
            if m < 0:
                raise ValueError(f"masses must be >= 0, got {m}")
            load = m * G
            p_free = dataclasses.replace(p0, piston_locked=0.0, load_mass=float(m), load_force=load)
            p_lock = dataclasses.replace(p_free, piston_locked=1.0)
            y = fa.rest_state(p_free, x_piston=1e-3)
            v1, f1, xi1, y = _run_loaded(y, float(cur), p_lock, dt, n_settle, np.inf)
            f_blk = float(np.mean(f1[int(0.8 * n_settle):n_settle]))
            v2, f2, xi2, y = _run_loaded(y, float(cur), p_free, dt, n_free, p_free.stroke - 3e-3)
            v, f, xi = np.concatenate([v1, v2]), np.concatenate([f1, f2]), np.concatenate([xi1, xi2])
            nf = v2.size
            n = n_settle + nf
            w0 = n_settle + max(int((1.0 - window_fraction) * nf), 0)
            w0 = min(w0, n - max(int(0.01 / dt), 2))
            w0 = max(w0, n_settle)
            vw = v[w0:n]
            vm, vs = float(np.mean(vw)), float(np.std(vw))
            rows["current"].append(float(cur))
            rows["mass"].append(float(m))
            rows["load"].append(load)
            rows["f_blocked"].append(f_blk)
            rows["force"].append(f_blk + load)
            rows["velocity"].append(vm)
            rows["velocity_std"].append(vs)
            rows["xi"].append(float(xi[n - 1]))
            rows["steady"].append(bool(vs < max(0.02 * abs(vm), 1e-3)) and nf >= int(0.02 / dt))
            rows["free_time"].append(nf * dt)
            tt = t0 + dt * np.arange(1, n + 1)
            t_all.append(tt)
            i_all.append(np.full(n, float(cur)))
            f_all.append(f[:n] + (noise_std * rng.standard_normal(n) if noise_std > 0 else 0.0))
            v_all.append(v[:n])
            l_all.append(np.full(n, load))
            runs.append(f"{tt[0]:.4f}-{tt[-1]:.4f}s:i={cur:g}A,m={m:g}kg,free_from={t0 + (n_settle + 1) * dt:.4f}s")
            t0 = tt[-1] + dt
    out: dict[str, Any] = {k: np.array(v) for k, v in rows.items()}
    out["path"] = None
    if path is not None:
        out["path"] = write_measured(
            path, np.concatenate(t_all),
            {"i": np.concatenate(i_all), "f": np.concatenate(f_all), "v": np.concatenate(v_all),
             "load": np.concatenate(l_all)},
            plant=fa.PLANT, units={"v": "m/s", "load": "N"}, allow_extra=True,
            metadata={"experiment": "hanging_mass_test (001 sec. 4.4)", "g_m_s2": G,
                      "load_model": "constant m*g on the piston (the plant's load_force)",
                      "settle_time_s": settle_time, "noise_std_N": noise_std, "runs": "; ".join(runs)},
        )
    return out


def prbs_locked(
    params: fa.ForceActuatorParams | None = None,
    *,
    duration: float = 2.0,
    amplitude: float = 0.1,
    clock_samples: int = 1,
    force_noise_std: float = 0.5,
    seed: int | None = 3,
) -> dict[str, np.ndarray]:
    """001 sec. 4.5 on the force actuator: piston locked at mid-stroke (``piston_locked = 1``
    is enforced), a low-amplitude PRBS current (``+-amplitude * rated_current``, bits of
    ``clock_samples`` samples) at 5 kHz (``SEED_T`` = 0.2 ms), sensed force ``k_s x_s``
    sampled at the end of each period plus white noise ``force_noise_std`` [N]. Returns
    ``t, i`` [A], ``f`` [N], ``f_true``."""
    p = params if params is not None else fa.ForceActuatorParams()
    p = dataclasses.replace(p, piston_locked=1.0)
    dt = fa.SEED_T
    t, i = prbs(duration, dt, clock_period=clock_samples * dt, amplitude=amplitude * p.rated_current, seed=seed)
    clamps = np.zeros(1, dtype=np.int64)
    states = simulate(_SPEC, p, i.reshape(-1, 1), fa.rest_state(p), dt, clamps=clamps)
    f = p.sensor_stiffness * states[1:, fa.XS]
    rng = np.random.default_rng(None if seed is None else seed + 1)
    noise = force_noise_std * rng.standard_normal(f.size) if force_noise_std > 0 else 0.0
    return {"t": t, "i": i, "f": f + noise, "f_true": f, "clamps": np.array(int(clamps[0]))}


def breakaway_test(params: fa.ForceActuatorParams, direction: int, rate: float = 5.0, dt: float = 2e-4,
                   slide: float = 5e-3) -> dict[str, np.ndarray]:
    """001 sec. 4.3's friction test (Table 2) on the virtual rig: the free piston
    (``piston_locked = 0``, no environment spring) at zero valve current, a push (``direction =
    +1``, the force pushing the piston in) or pull (``-1``) on the rod ramped from 0 at ``rate``
    [N/s] through ``load_force`` until the piston has slid ``slide`` [m]. Returns the traces
    ``t`` [s], ``applied`` [N], ``displacement`` [m] and ``velocity`` [m/s] of the piston
    (relative to the cylinder, in the push's direction) and the seal ``friction`` ``sigma0 |z|``
    [N] (a virtual friction cell), all signed along the push. Python (the kernels' own step)."""
    from hydro_envs.plants.force_actuator.kernels import step_serial
    from hydro_envs.sim.stiffness import substeps_from_stiffness

    p = dataclasses.replace(params, piston_locked=0.0, load_force=0.0, load_stiffness=0.0)
    n_sub = np.array([substeps_from_stiffness(fa.stiffness_modes(p), dt)[0]])
    Y = fa.rest_state(p)[None, :].copy()
    P = p.to_array()[None, :].copy()
    W = np.zeros((1, 5, fa.N_STATES))
    clamps = np.zeros(1, dtype=np.int64)
    U = np.zeros((1, 1))
    q0 = Y[0, fa.XP] + Y[0, fa.XS]
    f_top = 2.0 * max(p.coulomb_friction, p.stiction_retract, p.stiction_extend) + 10.0
    n = int(f_top / (rate * dt)) + 1
    out = {k: np.zeros(n) for k in ("t", "applied", "displacement", "velocity", "friction")}
    for k in range(n):
        f = rate * dt * k
        P[0, fa.I_FLOAD] = -direction * f
        step_serial(Y, U, P, dt, n_sub, W, clamps)
        dq = -direction * (Y[0, fa.XP] + Y[0, fa.XS] - q0)
        out["t"][k], out["applied"][k], out["displacement"][k] = (k + 1) * dt, f, dq
        out["velocity"][k] = -direction * (Y[0, fa.VP] + Y[0, fa.VS])
        out["friction"][k] = -direction * p.friction_stiffness * Y[0, fa.Z]
        if dq > slide:
            return {key: v[: k + 1] for key, v in out.items()}
    return out


def breakaway_force(params: fa.ForceActuatorParams, direction: int, rate: float = 5.0, dt: float = 2e-4,
                    slide: float = 5e-3) -> tuple[float, float]:
    """Breakaway of the seals measured by simulation (:func:`breakaway_test`, 001 sec. 4.3 /
    Table 2): ``(F_break, F_applied)`` [N], the peak seal friction (the force at the breaking
    point) and the applied force at that instant (larger by what accelerates the piston and
    eq (5)'s damping), signed as 001: push positive."""
    tr = breakaway_test(params, direction, rate, dt, slide)
    k = int(np.argmax(tr["friction"]))
    return direction * float(tr["friction"][k]), direction * float(tr["applied"][k])


def open_loop_force_response(params: fa.ForceActuatorParams, frequencies, amplitude: float = 0.1) -> np.ndarray:
    """001 sec. 4.7 "with the piston locked to the mount": first-harmonic sensed force over valve
    current [N/A] for current sines ``amplitude * rated_current`` held at 5 kHz (``SEED_T``), one
    run per frequency of at least 20 periods, the first half discarded."""
    p = dataclasses.replace(params, piston_locked=1.0)
    dt = fa.SEED_T
    out = []
    for f in np.asarray(frequencies, dtype=float):
        n = int(round(max(0.3, 20.0 / f) / dt))
        t = dt * np.arange(n)
        i = amplitude * p.rated_current * np.sin(2.0 * math.pi * f * t)
        st = simulate(_SPEC, p, i.reshape(-1, 1), fa.rest_state(p), dt)
        force = p.sensor_stiffness * st[1:, fa.XS]
        keep = t >= t[-1] - math.floor(0.5 * t[-1] * f) / f
        phasor = np.exp(-2j * math.pi * f * t[keep])
        out.append(np.mean((force[keep] - force[keep].mean()) * phasor) / np.mean(i[keep] * phasor))
    return np.array(out)
