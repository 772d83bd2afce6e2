"""Virtual experiments on the rodless cylinder (seed 004, ``004_f1423316a055addb.txt``).

* :func:`constant_command_run`: the friction measurement of sec. 3 -- hold the valve, let the
  slider reach a steady speed, read eq (1) from the pressure difference;
* :func:`small_signal_response`: the velocity response to a small valve step at mid-stroke,
  fitted with the linear model of eq (21);
* :func:`closed_loop_m_sequence`: the closed-loop direct identification record of sec. 4.2
  (a proportional loop with an M-sequence added to the controller output).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hydro_envs.excitation import m_sequence

from hydro_envs.plants.rodless_cylinder import model as rc
from hydro_envs.plants.rodless_cylinder.model import (
    PA, PB, V, Y, friction_compensation_gains, linearize_mid_stroke, piston_area, rest_state,
)
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.rodless_cylinder.spec import SPEC
from hydro_envs.sim.simulate import simulate
from hydro_envs.sim.stiffness import substeps_from_stiffness

__all__ = ["constant_command_run", "small_signal_response", "closed_loop_m_sequence", "presliding_test"]


def constant_command_run(params: RodlessCylinderParams, command: float, *, dt: float = 1e-3,
                         window: tuple[float, float] = (0.35, 0.65), max_time: float = 30.0):
    """004 sec. 3 friction measurement: hold the valve at ``command`` [V] and read eq (1).

    The slider starts at rest at the end of stroke it moves away from (chambers at p_0); the
    valve is held constant, the slider reaches a steady speed, and while it crosses the
    ``window`` (fractions of the stroke) the mean velocity and the mean pressure force
    ``A (p_a - p_b)`` are taken. At constant speed eq (1) ``F_f = A_a p_a - A_b p_b`` holds
    (minus F_L). Returns ``(v_mean, f_mean, states)``; ``v_mean`` is NaN if the window is
    not crossed within ``max_time``.
    """
    sign = 1.0 if command > params.command_centre else -1.0
    y_start = 0.002 * params.stroke if sign > 0 else 0.998 * params.stroke
    y0 = rest_state(params, y_start)
    n = int(round(max_time / dt))
    lo, hi = window[0] * params.stroke, window[1] * params.stroke
    # simulate in chunks until the window has been crossed
    states = [y0[None, :]]
    y = y0
    chunk = int(round(0.5 / dt))
    done = 0
    while done < n:
        seg = simulate(SPEC, params, np.full(chunk, command), y, dt)[1:]
        states.append(seg)
        y = seg[-1]
        done += chunk
        if (sign > 0 and y[Y] > hi) or (sign < 0 and y[Y] < lo):
            break
    s = np.concatenate(states)
    inside = np.flatnonzero((s[:, Y] > lo) & (s[:, Y] < hi))
    if inside.size < 3 or not ((sign > 0 and s[-1, Y] > hi) or (sign < 0 and s[-1, Y] < lo)):
        return float("nan"), float("nan"), s
    i0, i1 = inside[0], inside[-1]
    v_mean = (s[i1, Y] - s[i0, Y]) / ((i1 - i0) * dt)
    a = piston_area(params)
    f_mean = float(np.mean(a * (s[i0 : i1 + 1, PA] - s[i0 : i1 + 1, PB]))) - params.load_force
    return float(v_mean), f_mean, s


def small_signal_response(params: RodlessCylinderParams, delta_u: float = 0.01, *, dt: float = 1e-4,
                          duration: float = 0.08):
    """Velocity response of the friction-free plant to a small valve step at mid-stroke.

    Starts from the centre equilibrium (slider at L/2, chambers at p_0 and T_s, spool at the
    centre), steps the command from 5 V to ``5 V + delta_u`` and fits the linear model of
    eq (21) in velocity form, ``v/x_v = K_T w^2 / (s^2 + 2 zeta w s + w^2)``, in series with
    the known spool lag, to the simulated velocity by least squares. Returns
    ``dict(k_t, zeta, omega_n, t, v, v_fit)``.
    """
    from scipy.optimize import least_squares
    from scipy.signal import lsim

    p = dataclasses.replace(
        params, static_friction=0.0, coulomb_friction=0.0, viscous_friction=0.0,
        bristle_stiffness=0.0, bristle_damping=0.0, load_force=0.0,
    )
    y0 = rest_state(p, 0.5 * p.stroke)
    n = int(round(duration / dt))
    s = simulate(SPEC, p, np.full(n, p.command_centre + delta_u), y0, dt)
    t = dt * np.arange(n + 1)
    v = s[:, V]
    x_step = p.spool_stroke / (p.command_max - p.command_centre) * delta_u
    wv, zv = p.valve_natural_frequency, p.valve_damping
    lin = linearize_mid_stroke(p)

    def model(theta):
        k_t, zeta, w = theta
        num = np.polymul([k_t * w * w], [wv * wv])
        den = np.polymul([1.0, 2.0 * zeta * w, w * w], [1.0, 2.0 * zv * wv, wv * wv])
        return lsim((num, den), np.full(t.size, x_step), t)[1]

    def resid(theta):
        return (model(theta) - v) / (abs(lin.k_t * x_step) + 1e-30)

    sol = least_squares(resid, x0=[lin.k_t, max(lin.zeta, 0.01), lin.omega_n], method="lm", x_scale="jac")
    k_t, zeta, w = sol.x
    return {"k_t": float(k_t), "zeta": float(zeta), "omega_n": float(abs(w)), "t": t, "v": v, "v_fit": model(sol.x)}


def closed_loop_m_sequence(
    params: RodlessCylinderParams | None = None,
    *,
    dt: float = 0.01,
    kp: float = 50.0,
    n_bits: int = 10,
    amplitude: float = 0.3,
    samples_per_bit: int = 1,
    periods: int = 2,
    position_noise_std: float = 0.0,
    seed: int | None = 0,
    friction_compensation: bool = False,
) -> dict[str, np.ndarray]:
    """004 sec. 4.2 on the rodless cylinder: a proportional position loop holds the slider at
    mid-stroke, ``u = u_c + kp (r - y_m) + m(t)`` with the M-sequence ``m`` (``+-amplitude`` V,
    ``2**n_bits - 1`` bits of ``samples_per_bit`` samples, ``periods`` times) added to the
    controller output ("the input signal is the superposition of the controller output signal
    and M-sequence signal"); ``u`` is clipped to 0..command_max and held over ``dt``.

    Returns ``t, u`` [V] (the ARX input), ``u_valve`` [V] (the command the valve gets; ``u``
    itself without compensation), ``y`` [m] (measured position, the ARX output; white noise
    ``position_noise_std`` from ``default_rng(seed)``), ``y_true`` and ``m``. The sample time
    of eq (32) is not printed; 10 ms (the default) puts our plant's 25 Hz mid-stroke resonance
    at the angle of eq (32)'s complex pair (1.2 rad, i.e. about 20 Hz at 10 ms). ``y[k]`` is
    sampled before ``u[k]`` is applied, so the loop has the one-sample delay direct
    identification needs (arx module docstring).

    ``friction_compensation``: 004 sec. 4.1 adds friction compensation to the loop (Fig. 11)
    without printing it. This option adds one: the Table 2 curve at the backward-difference
    velocity of the measured position, turned into a valve command by eq (27)
    (:func:`~.model.friction_compensation_gains`). ``u`` is then the controller output plus the
    M-sequence (the compensation is inside the identified system, as in Fig. 11).
    """
    kernels = SPEC.kernels
    p = params if params is not None else RodlessCylinderParams()
    if not (dt > 0 and math.isfinite(dt)):
        raise ValueError(f"dt must be > 0 s, got {dt}")
    m = m_sequence(n_bits, amplitude=amplitude, samples_per_bit=samples_per_bit, periods=periods)
    n = m.size
    n_sub = substeps_from_stiffness(rc.stiffness_modes(p), dt)[0]
    Y = rc.rest_state(p, 0.5 * p.stroke)[None, :].copy()
    P = p.to_array()[None, :]
    W = np.zeros((1, 5, rc.N_STATES))
    clamps = np.zeros(1, dtype=np.int64)
    nsub = np.array([n_sub], dtype=np.int64)
    U = np.zeros((1, 1))
    rng = np.random.default_rng(seed)
    noise = position_noise_std * rng.standard_normal(n) if position_noise_std > 0 else np.zeros(n)
    ref = 0.5 * p.stroke
    u = np.empty(n)
    u_valve = np.empty(n)
    y_true = np.empty(n)
    static, dynamic = friction_compensation_gains(p) if friction_compensation else (0.0, 0.0)
    f_prev = 0.0
    for k in range(n):
        y_true[k] = Y[0, rc.Y]
        y_m = y_true[k] + noise[k]
        comp = 0.0
        if friction_compensation and k > 0:
            f = float(rc.steady_friction(p, (y_m - y_true[k - 1] - noise[k - 1]) / dt))  # Table 2 curve
            comp = static * f + dynamic * (f - f_prev) / dt
            f_prev = f
        u_ctrl = p.command_centre + kp * (ref - y_m) + m[k]
        u_valve[k] = min(max(u_ctrl + comp, 0.0), p.command_max)
        u[k] = u_valve[k] if not friction_compensation else u_ctrl
        U[0, 0] = u_valve[k]
        kernels.step_serial(Y, U, P, dt, nsub, W, clamps)
    return {"t": np.arange(n) * dt, "u": u, "u_valve": u_valve, "y": y_true + noise, "y_true": y_true, "m": m,
            "clamps": np.array(int(clamps[0]))}


def presliding_test(params: RodlessCylinderParams | None = None, *, command_offset: float = 0.03,
                    duration: float = 2.0, dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """The seals' pre-sliding loading branch (004 Fig. 4: "a small displacement before the
    continuous sliding"), measured on the rig at rest: the valve held ``command_offset`` [V] off
    its centre from rest at mid-stroke, so the pressure difference builds slowly; until the seals
    break away the slider moves only by their elastic deflection. Returns ``(y - y0, A (p_a - p_b))``
    [m, N] up to the largest force before breakaway (noise-free). Fitted by
    :func:`identification.friction.bristle_stiffness_from_loading`."""
    p = params if params is not None else RodlessCylinderParams()
    y0 = rest_state(p, 0.5 * p.stroke)
    n = int(round(duration / dt))
    st = simulate(SPEC, p, np.full(n, p.command_centre + float(command_offset)), y0, dt)
    x = st[:, Y] - st[0, Y]
    f = piston_area(p) * (st[:, PA] - st[:, PB])
    k = int(np.argmax(f)) + 1
    return x[:k], f[:k]
