r"""Virtual friction test of the servo cylinder: 002 sec. 4's square wave, measured as a rig would.

002 sec. 4: "a square control signal (u) was applied for the actuator for 150 seconds. The
amplitude of the control signal was increased with a 0.05 V step in every period"; in each
constant-velocity regime the velocity and the chamber pressures are averaged after the
transients and ``F_f = A (P1 - P2)`` (eqs (9)-(10)). :func:`run_friction_experiment` runs it
and returns the record a rig would log (sensors of :class:`~hydro_envs.data.sensors.SensorModel`);
the identification package's ``friction_points_from_square_wave`` extracts the points.

*Choice of the periods (the paper's figure is missing).* The cylinder has end stops at 0 and
69.6 mm and moves at ``v(a) ~ v_nl a / 10 V`` (orifice law, ``v_nl`` = 0.66 m/s at full
opening, friction changes it by < 1 %). A fixed period ``T`` cannot work: with amplitudes
``0.05 k`` V for ``k = 1..150/T`` the last half-period travels
``v_nl (0.05 * 150 / T) / 10 * T / 2 = 0.25 m`` whatever ``T`` is -- 3.6 strokes. So every
period is chosen for the same travel: ``T_k = 2 * travel / v(a_k)``, with
``travel = travel_fraction * L`` (default 0.75 L = 52 mm), centred in the stroke (the piston
starts at ``(L - travel) / 2`` and the first half-period moves it forward). Small amplitudes
get long periods (31 s at 0.05 V: long averaging windows where the Stribeck dip is), large
amplitudes short ones; the amplitude stops growing when the next period would end after
``duration`` (default 150 s, the paper's) or fall below ``period_min`` (default 0.4 s: the
half-period must outlast the reversal transient of the 664 rad/s hydraulic mode and still
leave an averaging window). With the defaults that is 68 periods from 0.05 V to 3.40 V
(3.3 mm/s to 0.23 m/s, periods 31 s to 0.46 s) in 150.0 s; the piston stays between 8.5 and
61 mm (never near the stops). ``period_max`` caps the long periods when a shorter test is
wanted.

*Finding on the nominal plant (documented in the tests):* below about 18 mm/s the Stribeck
slope ``-(F_s - F_c)/v_s e^{-v/v_s}`` (down to -2000 N s/m) exceeds the viscous damping
(250 N s/m) and the valve's flow-pressure damping (critically lapped, no leakage), so the piston
sticks and slips on its LuGre seals instead of sliding steadily. The averaged force of such a
window is the cycle average, not ``F_f(mean v)`` (about 1 N low at 3-10 mm/s), which biases a
Stribeck fit (F_s low, v_s high; F_c and F_v are well determined by the steady windows). The
points' ``force_std`` exposes it (20 N at 3.3 mm/s to 85 N at 16.7 mm/s, below 0.2 N from 20 to
80 mm/s). With the viscous damping raised to 2500 N s/m the sliding is stable at every speed and
the method returns the plant's law exactly (tests).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hydro_envs.data.measured import MeasuredData, write_measured
from hydro_envs.data.sensors import SensorModel
from hydro_envs.plants.servo_cylinder import model as sc
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.plants.servo_cylinder.spec import SPEC
from hydro_envs.sim.simulate import simulate

__all__ = [
    "simulate_servo_cylinder",
    "FrictionSchedule",
    "friction_test_schedule",
    "square_wave_command",
    "FrictionExperiment",
    "run_friction_experiment",
    "presliding_test",
]


def simulate_servo_cylinder(
    params: ServoCylinderParams | None,
    u: Any,
    *,
    dt: float = 1e-3,
    y0: Any = None,
    x0: float | None = None,
) -> np.ndarray:
    """States ``(n + 1, 7)`` (x, v, p1, p2, xv, vv, z; SI) under the held commands ``u[k]`` [V].

    Runs :func:`hydro_envs.sim.simulate`, the same RK4 kernel and sub-steps (from the
    stiffness bound) as the environments. ``y0`` defaults to
    rest at ``x0`` (default mid-stroke) with both chambers at the valve's null pressure
    ``(p_s + p_R) / 2``.
    """
    p = params if params is not None else ServoCylinderParams()
    u = np.ascontiguousarray(np.asarray(u, dtype=float).reshape(-1, 1))
    if not np.all(np.isfinite(u)):
        raise ValueError("command u contains NaN or inf")
    if y0 is None:
        y = np.zeros(sc.N_STATES)
        y[sc.X] = 0.5 * p.stroke if x0 is None else float(x0)
        y[sc.P1] = y[sc.P2] = 0.5 * (p.supply_pressure + p.tank_pressure)
    else:
        y = np.array(y0, dtype=float)
        if y.shape != (sc.N_STATES,):
            raise ValueError(f"y0 must have shape ({sc.N_STATES},), got {y.shape}")
    return simulate(SPEC, p, u, y, float(dt))


@dataclass(frozen=True)
class FrictionSchedule:
    """Square-wave schedule: period ``k`` holds ``+amplitudes[k]`` for ``half_steps[k]``
    samples, then ``-amplitudes[k]`` for as many."""

    amplitudes: np.ndarray
    half_steps: np.ndarray
    dt: float
    travel: float
    x_start: float

    @property
    def periods(self) -> np.ndarray:
        return 2.0 * self.half_steps * self.dt

    @property
    def duration(self) -> float:
        return float(2 * int(self.half_steps.sum()) * self.dt)

    @property
    def n_steps(self) -> int:
        return 2 * int(self.half_steps.sum())


def friction_test_schedule(
    params: ServoCylinderParams | None = None,
    *,
    duration: float = 150.0,
    amplitude_step: float = 0.05,
    amplitude_start: float | None = None,
    amplitudes: Sequence[float] | None = None,
    travel_fraction: float = 0.75,
    period_min: float = 0.4,
    period_max: float | None = None,
    dt: float = 1e-3,
) -> FrictionSchedule:
    """Amplitudes and periods of the 002 sec. 4 square-wave test (see the module docstring).

    Default: amplitudes ``amplitude_start + k * amplitude_step`` (start = step = 0.05 V), each
    period chosen for a half-period travel of ``travel_fraction * stroke`` at the orifice-law
    speed, stopping before ``duration`` is exceeded or the period drops below ``period_min``.
    ``amplitudes`` (explicit list) overrides the ramp (then all are used; a period shorter
    than ``period_min`` raises, since the travel would not fit). ``period_max`` caps the
    long low-amplitude periods (their half-period then travels less than ``travel``).
    """
    p = params if params is not None else ServoCylinderParams()
    if not (0.0 < travel_fraction < 1.0):
        raise ValueError(f"travel_fraction must be in (0, 1), got {travel_fraction}")
    for name, val in (("duration", duration), ("period_min", period_min), ("dt", dt),
                      ("amplitude_step", amplitude_step)):
        if not (math.isfinite(val) and val > 0):
            raise ValueError(f"{name} must be > 0, got {val}")
    travel = travel_fraction * p.stroke
    k_v = sc.no_load_velocity(p) / p.command_max  # m/s per V, orifice law, no load

    if period_max is not None and not (period_max >= period_min):
        raise ValueError(f"period_max = {period_max} s must be >= period_min = {period_min} s")

    def half_steps_for(a: float) -> int:
        half = travel / (k_v * a)
        if period_max is not None:
            half = min(half, 0.5 * period_max)
        return int(round(half / dt))

    amps: list[float] = []
    halves: list[int] = []
    if amplitudes is not None:
        for a in amplitudes:
            a = float(a)
            if not (0.0 < a <= p.command_max):
                raise ValueError(f"amplitude {a} V outside (0, {p.command_max}] V")
            h = half_steps_for(a)
            if 2 * h * dt < period_min - 1e-12:
                raise ValueError(
                    f"amplitude {a} V needs a period of {2 * h * dt:.3g} s for the travel "
                    f"{travel * 1e3:.3g} mm, below period_min = {period_min} s; lower "
                    "travel_fraction or the amplitude"
                )
            amps.append(a)
            halves.append(h)
    else:
        a = amplitude_step if amplitude_start is None else float(amplitude_start)
        total = 0
        while a <= p.command_max + 1e-12:
            h = half_steps_for(a)
            if 2 * h * dt < period_min - 1e-12 or (total + 2 * h) * dt > duration + 1e-9:
                break
            amps.append(a)
            halves.append(h)
            total += 2 * h
            a = round(a + amplitude_step, 12)
    if not amps:
        raise ValueError(
            "no period fits: the first amplitude's period exceeds the duration; raise "
            "duration or amplitude_start, or lower travel_fraction"
        )
    return FrictionSchedule(
        amplitudes=np.array(amps), half_steps=np.array(halves, dtype=np.int64), dt=float(dt),
        travel=float(travel), x_start=float(0.5 * (p.stroke - travel)),
    )


def square_wave_command(schedule: FrictionSchedule) -> np.ndarray:
    """Held commands ``u[k]`` [V], one per step (``schedule.n_steps`` values)."""
    parts = []
    for a, h in zip(schedule.amplitudes, schedule.half_steps):
        parts.append(np.full(int(h), a))
        parts.append(np.full(int(h), -a))
    return np.concatenate(parts)


@dataclass
class FrictionExperiment:
    """A virtual 002 sec. 4 experiment: the measured data, its schedule and the truth."""

    data: MeasuredData
    schedule: FrictionSchedule
    states: np.ndarray
    params: ServoCylinderParams
    path: Path | None = None
    clamps: int = 0


def run_friction_experiment(
    params: ServoCylinderParams | Mapping[str, float] | None = None,
    *,
    sensors: SensorModel | None = None,
    seed: int | None = 0,
    path: str | os.PathLike[str] | None = None,
    dt: float = 1e-3,
    **schedule_kwargs: Any,
) -> FrictionExperiment:
    """Run the constant-velocity friction test of 002 sec. 4 on the servo cylinder.

    ``schedule_kwargs`` go to :func:`friction_test_schedule` (``duration``, ``amplitude_step``,
    ``amplitude_start``, ``amplitudes``, ``travel_fraction``, ``period_min``). The record
    (channels ``u, x, p1, p2`` of plant ``servo_cylinder`` at ``1/dt``) passes through
    ``sensors`` (default ideal) with noise drawn from ``numpy.random.default_rng(seed)`` and
    is written to ``path`` (measured-data format) if given. The truth states are returned too.
    """
    if params is None:
        p = ServoCylinderParams()
    elif isinstance(params, ServoCylinderParams):
        p = params
    else:
        p = ServoCylinderParams.from_mapping(params)
    sensors = sensors or SensorModel()
    sched = friction_test_schedule(p, dt=dt, **schedule_kwargs)
    u = square_wave_command(sched)
    y0 = np.zeros(sc.N_STATES)
    y0[sc.X] = sched.x_start
    y0[sc.P1] = y0[sc.P2] = 0.5 * (p.supply_pressure + p.tank_pressure)
    counts = np.zeros(1, dtype=np.int64)
    states = simulate(SPEC, p, u.reshape(-1, 1), y0, float(dt), clamps=counts)
    clamps = int(counts[0])
    rng = np.random.default_rng(seed)
    x_m, (p1_m, p2_m) = sensors.apply(dt, states[:, sc.X], [states[:, sc.P1], states[:, sc.P2]], rng)
    t = np.arange(states.shape[0]) * dt
    u_rec = np.append(u, 0.0)  # command held from t_k; valve commanded to zero at the end
    meta = {
        "source": "hydro_envs.plants.servo_cylinder.friction_test.run_friction_experiment (virtual, simulated)",
        "experiment": "002 sec. 4 square-wave constant-velocity friction test",
        "sample_rate": repr(1.0 / dt),
        "amplitude_first": repr(float(sched.amplitudes[0])),
        "amplitude_last": repr(float(sched.amplitudes[-1])),
        "n_periods": str(len(sched.amplitudes)),
        "travel": repr(sched.travel),
        "seed": str(seed),
        "position_quantization": repr(sensors.position_quantization),
        "position_noise_std": repr(sensors.position_noise_std),
        "pressure_noise_std": repr(sensors.pressure_noise_std),
        "pressure_filter_hz": repr(sensors.pressure_filter_hz),
        "piston_area": repr(p.piston_area),
    }
    channels = {"u": u_rec, "x": x_m, "p1": p1_m, "p2": p2_m}
    data = MeasuredData(plant="servo_cylinder", t=t, channels=channels,
                        units={"t": "s", "u": "V", "x": "m", "p1": "Pa", "p2": "Pa"},
                        metadata=meta)
    written = None
    if path is not None:
        written = write_measured(path, data)
    return FrictionExperiment(data=data, schedule=sched, states=states, params=p, path=written,
                              clamps=int(clamps))


def presliding_test(params: ServoCylinderParams | None = None, *, command: float = 3e-3, duration: float = 1.0,
                    dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """The seals' pre-sliding loading branch, measured on the rig at rest: a tiny constant valve
    command ``command`` [V] (3 mV: the load pressure rises by about 0.2 MPa/s) from rest at
    mid-stroke; until the seals break away the piston moves only by their bristles' elastic
    deflection. Returns ``(x - x0, A (p1 - p2))`` [m, N] up to the first sample beyond the largest
    force before breakaway (a precision scale and pressure transducers read these; noise-free
    here). Fitted by :func:`identification.friction.bristle_stiffness_from_loading`."""
    p = params if params is not None else ServoCylinderParams()
    n = int(round(duration / dt))
    st = simulate_servo_cylinder(p, np.full(n, float(command)), dt=dt)
    x = st[:, sc.X] - st[0, sc.X]
    f = p.piston_area * (st[:, sc.P1] - st[:, sc.P2])
    k = int(np.argmax(f)) + 1  # the breakaway: the force drops (or stops rising) as the piston slips
    return x[:k], f[:k]
