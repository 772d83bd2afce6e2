r"""Virtual identification experiments, steady-window extraction, excitation signals, and the
measured seal-friction data.

1. **Constant-velocity friction test of 002 sec. 4** on the servo cylinder
   (:func:`run_friction_experiment`). 002: "a square control signal (u) was applied for the
   actuator for 150 seconds. The amplitude of the control signal was increased with a 0.05 V
   step in every period"; in each constant-velocity regime the velocity and the chamber
   pressures are averaged after the transients and ``F_f = A (P1 - P2)`` (eqs (9)-(10)).

   *Choice of the periods (the paper's figure is missing).* The cylinder has end stops at 0
   and 69.6 mm and moves at ``v(a) ~ v_nl a / 10 V`` (orifice law, ``v_nl`` = 0.66 m/s at full
   opening, friction changes it by < 1 %). A fixed period ``T`` cannot work: with amplitudes
   ``0.05 k`` V for ``k = 1..150/T`` the last half-period travels
   ``v_nl (0.05 * 150 / T) / 10 * T / 2 = 0.25 m`` whatever ``T`` is -- 3.6 strokes. So every
   period is chosen for the same travel: ``T_k = 2 * travel / v(a_k)``, with
   ``travel = travel_fraction * L`` (default 0.75 L = 52 mm), centred in the stroke
   (the piston starts at ``(L - travel) / 2`` and the first half-period moves it forward).
   Small amplitudes get long periods (31 s at 0.05 V: long averaging windows where the
   Stribeck dip is), large amplitudes short ones; the amplitude stops growing when the next
   period would end after ``duration`` (default 150 s, the paper's) or fall below
   ``period_min`` (default 0.4 s: the half-period must outlast the reversal transient of the
   664 rad/s hydraulic mode and still leave an averaging window). With the defaults that is
   68 periods from 0.05 V to 3.40 V (3.3 mm/s to 0.23 m/s, periods 31 s to 0.46 s) in
   150.0 s; the piston stays between 8.5 and 61 mm (never near the stops).
   ``period_max`` caps the long periods when a shorter test is wanted.

   *Finding on the nominal plant (documented in the tests):* up to 20 mm/s the Stribeck
   slope ``-(F_s - F_c)/v_s e^{-v/v_s}`` (down to -2000 N s/m) exceeds the viscous damping
   (250 N s/m) and the valve's flow-pressure damping (critically lapped, no leakage: damping
   ratio ~1e-3), so the piston runs in a friction-induced limit cycle near the hydraulic
   frequency (~100 Hz, velocity swinging between ~0 and 2 v). The averaged force of such a
   window is the cycle average, not ``F_f(mean v)``: 1-1.6 N low at 3-10 mm/s, which biases a
   Stribeck fit (ideal sensors: F_s -6 %, v_s +22 %; F_c, F_v within 0.3 %).
   ``FrictionPoints.force_std`` exposes it (11-110 N in those windows, < 0.2 N from 25 to
   80 mm/s). With the viscous damping raised to 2500 N s/m the sliding is stable at every
   speed and the method returns the plant's law exactly (tests).

2. **Constant-velocity test of 004 sec. 3.2, plant-agnostic** (:func:`constant_velocity_test`):
   for each valve command a caller-supplied ``simulate(command)`` returns time series (time,
   position or velocity, and force or chamber pressures); steady windows are found
   automatically (:func:`steady_windows`) and ``F_f = A_a p_a - A_b p_b`` (004 eq (1)) averaged.

3. **Excitation signals**: M-sequences / PRBS (:func:`m_sequence`, :func:`prbs`, from
   ``scipy.signal.max_len_seq``) and exponential (log) sine sweeps (:func:`log_sine_sweep`).

4. **Measured seal friction** (CC0, ``EvaZillen/3D-printed-pneumatic-actuator``): the
   plant ``seal_friction`` channel set and :func:`load_seal_friction`, which reads the
   original whitespace format or a measured-data CSV (see its docstring), and
   :func:`seal_friction_points`.

Sensor models (:class:`SensorModel`): additive Gaussian noise, encoder quantisation
(0.03 mm, 002 sec. 3: "a position measurement resolution of 0.03mm per increment") and a
causal low-pass on the pressures (002 sec. 4: "the pressure signals were filtered").
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal

from hydro_envs.excitation import log_sine_sweep, log_sweep_frequency, m_sequence, prbs  # noqa: F401  (re-exported)

from hydro_envs import registry
from hydro_envs.data.measured import MeasuredData, MeasuredDataError, load_measured, write_measured
from hydro_envs.plants.servo_cylinder import model as sc
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.sim.simulate import simulate
from hydro_envs.sim.stiffness import substeps_from_stiffness
from identification.friction import FrictionPoints, InsufficientDataError, chamber_force

SERVO_SPEC = registry.get("servo_cylinder")

__all__ = [
    "SensorModel",
    "simulate_servo_cylinder",
    "FrictionSchedule",
    "friction_test_schedule",
    "square_wave_command",
    "FrictionExperiment",
    "run_friction_experiment",
    "friction_points_from_square_wave",
    "smoothed_velocity",
    "steady_windows",
    "constant_velocity_points",
    "constant_velocity_test",
    "m_sequence",
    "prbs",
    "log_sine_sweep",
    "log_sweep_frequency",
    "SEAL_FRICTION_PLANT",
    "SEAL_BORE",
    "load_seal_friction",
    "seal_friction_points",
    "fit_compensator_viscous",
    "rodless_closed_loop_m_sequence",
    "force_actuator_prbs_locked",
]


# ======================================================================================
# sensors
# ======================================================================================


@dataclass(frozen=True)
class SensorModel:
    """Measurement model applied to the simulated truth before writing the data file.

    ``position_noise_std`` [m] and ``pressure_noise_std`` [Pa] white Gaussian noise (per
    sample), ``position_quantization`` [m] encoder increment (rounding), ``pressure_filter_hz``
    cut-off of a causal 2nd-order Butterworth low-pass on the pressures (None: unfiltered).
    """

    position_noise_std: float = 0.0
    position_quantization: float = 0.0
    pressure_noise_std: float = 0.0
    pressure_filter_hz: float | None = None

    def __post_init__(self) -> None:
        for name in ("position_noise_std", "position_quantization", "pressure_noise_std"):
            val = getattr(self, name)
            if not (math.isfinite(val) and val >= 0.0):
                raise ValueError(f"SensorModel.{name} must be finite and >= 0, got {val}")
        if self.pressure_filter_hz is not None and not (
            math.isfinite(self.pressure_filter_hz) and self.pressure_filter_hz > 0
        ):
            raise ValueError(
                f"SensorModel.pressure_filter_hz must be > 0 Hz or None, got {self.pressure_filter_hz}"
            )

    @classmethod
    def ideal(cls) -> "SensorModel":
        return cls()

    @classmethod
    def realistic(cls) -> "SensorModel":
        """0.03 mm encoder (002 sec. 3), 20 kPa pressure noise (assumed: 0.1 % of a 20 MPa
        transducer), pressures low-passed at 50 Hz (assumed; 002 sec. 4 filters them)."""
        return cls(position_quantization=3e-5, pressure_noise_std=2e4, pressure_filter_hz=50.0)

    def apply(self, dt: float, x: np.ndarray, pressures: Sequence[np.ndarray],
              rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
        x_m = np.array(x, dtype=float)
        if self.position_noise_std > 0:
            x_m = x_m + rng.normal(0.0, self.position_noise_std, x_m.shape)
        if self.position_quantization > 0:
            q = self.position_quantization
            x_m = q * np.floor(x_m / q + 0.5)
        out = []
        for p in pressures:
            p_m = np.array(p, dtype=float)
            if self.pressure_noise_std > 0:
                p_m = p_m + rng.normal(0.0, self.pressure_noise_std, p_m.shape)
            if self.pressure_filter_hz is not None:
                fs = 1.0 / dt
                wn = min(self.pressure_filter_hz / (0.5 * fs), 0.99)
                sos = signal.butter(2, wn, output="sos")
                zi = signal.sosfilt_zi(sos) * p_m[0]
                p_m, _ = signal.sosfilt(sos, p_m, zi=zi)
            out.append(p_m)
        return x_m, out


# ======================================================================================
# simulation on the batched kernel
# ======================================================================================


def simulate_servo_cylinder(
    params: ServoCylinderParams | None,
    u: Any,
    *,
    dt: float = 1e-3,
    y0: Any = None,
    x0: float | None = None,
) -> np.ndarray:
    """States ``(n + 1, 6)`` (x, v, p1, p2, xv, vv; SI) under the held commands ``u[k]`` [V].

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
    return simulate(SERVO_SPEC, p, u, y, float(dt))


# ======================================================================================
# 002 sec. 4: square-wave constant-velocity friction test
# ======================================================================================


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
    states = simulate(SERVO_SPEC, p, u.reshape(-1, 1), y0, float(dt), clamps=counts)
    clamps = int(counts[0])
    rng = np.random.default_rng(seed)
    x_m, (p1_m, p2_m) = sensors.apply(dt, states[:, sc.X], [states[:, sc.P1], states[:, sc.P2]], rng)
    t = np.arange(states.shape[0]) * dt
    u_rec = np.append(u, 0.0)  # command held from t_k; valve commanded to zero at the end
    meta = {
        "source": "identification.experiments.run_friction_experiment (virtual, simulated)",
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


def _runs_of_constant(u: np.ndarray, tol: float) -> list[tuple[int, int]]:
    """Index ranges ``[i0, i1)`` where ``u`` stays within ``tol`` of its first value."""
    runs = []
    i0 = 0
    n = u.size
    for i in range(1, n + 1):
        if i == n or abs(u[i] - u[i0]) > tol:
            runs.append((i0, i))
            i0 = i
    return runs


def friction_points_from_square_wave(
    data: MeasuredData,
    area: float | None = None,
    *,
    settle_time: float = 0.05,
    window_fraction: float = 0.5,
    command_tol: float = 1e-9,
    min_samples: int = 10,
    correct_inertia: float | None = None,
) -> FrictionPoints:
    """Constant-velocity points of a square-wave test (002 sec. 4 algorithm).

    Segments are the runs of constant nonzero command ``u``. In each, the window is the last
    ``window_fraction`` of the segment, starting at least ``settle_time`` after the switch
    ("after the transients, set the average ... over a given time period"). Velocity = slope of
    a least-squares line through the position samples of the window (robust to encoder
    quantisation); force = ``A * mean(p1 - p2)`` (eq (10)); pressure = mean of
    ``(p1 + p2) / 2``; ``force_std`` = standard deviation of the force samples.
    ``correct_inertia`` = mass [kg] subtracts ``m a`` with ``a`` from a quadratic fit (zero in
    a truly steady window). ``area`` defaults to the file's ``piston_area`` metadata.
    """
    for ch in ("u", "x", "p1", "p2"):
        if ch not in data:
            raise MeasuredDataError(None, f"square-wave friction data need channel {ch!r}; "
                                    f"the data have t, {', '.join(data.names)}", column=ch)
    if area is None:
        if "piston_area" not in data.metadata:
            raise ValueError("area is required (no 'piston_area' in the data's metadata)")
        area = float(data.metadata["piston_area"])
    if not (0.0 < window_fraction <= 1.0):
        raise ValueError(f"window_fraction must be in (0, 1], got {window_fraction}")
    t, u, x = data.t, data["u"], data["x"]
    dp = data["p1"] - data["p2"]
    pm = 0.5 * (data["p1"] + data["p2"])
    rows: dict[str, list[float]] = {k: [] for k in
                                    ("v", "f", "p", "fs", "n", "t0", "t1", "c")}
    for i0, i1 in _runs_of_constant(u, command_tol):
        if u[i0] == 0.0:
            continue
        seg_t0, seg_t1 = t[i0], t[i1 - 1]
        w0 = max(seg_t0 + settle_time, seg_t1 - window_fraction * (seg_t1 - seg_t0))
        sel = np.flatnonzero((t >= w0) & (t <= seg_t1))
        sel = sel[(sel >= i0) & (sel < i1)]
        if sel.size < max(min_samples, 3):
            continue
        tt = t[sel] - t[sel].mean()
        v = float(np.polyfit(tt, x[sel], 1)[0])
        force = area * dp[sel]
        f_mean = float(force.mean())
        if correct_inertia is not None:
            acc = 2.0 * float(np.polyfit(tt, x[sel], 2)[0])
            f_mean -= correct_inertia * acc
        rows["v"].append(v)
        rows["f"].append(f_mean)
        rows["p"].append(float(pm[sel].mean()))
        rows["fs"].append(float(force.std()))
        rows["n"].append(sel.size)
        rows["t0"].append(float(t[sel[0]]))
        rows["t1"].append(float(t[sel[-1]]))
        rows["c"].append(float(u[i0]))
    if not rows["v"]:
        raise InsufficientDataError(
            "no constant-command segment long enough for a steady window "
            f"(settle_time {settle_time} s, min_samples {min_samples})"
        )
    return FrictionPoints(
        v=rows["v"], force=rows["f"], pressure=rows["p"], force_std=rows["fs"],
        n_samples=rows["n"], t_start=rows["t0"], t_end=rows["t1"], command=rows["c"],
        group=np.arange(len(rows["v"])), meta={"area": area, "source": "002 sec. 4 square wave"},
    )


# ======================================================================================
# plant-agnostic steady windows (004 sec. 3.2)
# ======================================================================================


def smoothed_velocity(t: np.ndarray, x: np.ndarray, smooth_time: float) -> np.ndarray:
    """Velocity from positions: Savitzky-Golay derivative (quadratic) over ``smooth_time``."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    dt = float(np.median(np.diff(t)))
    n = max(5, int(round(smooth_time / dt)) | 1)
    if n > x.size:
        n = x.size if x.size % 2 else x.size - 1
    if n < 3:
        return np.gradient(x, t)
    # resample-free: savgol assumes uniform steps; records with gaps use np.gradient on the
    # smoothed position instead
    if np.max(np.diff(t)) > 1.5 * dt:
        xs = signal.savgol_filter(x, n, 2)
        return np.gradient(xs, t)
    return signal.savgol_filter(x, n, 2, deriv=1, delta=dt)


def steady_windows(
    t: Any,
    v: Any,
    *,
    min_duration: float = 0.2,
    rel_tol: float = 0.15,
    abs_tol: float = 0.0,
    v_min: float | None = None,
    trim: float = 0.1,
) -> list[tuple[int, int]]:
    """Index ranges ``[i0, i1)`` where the (smoothed) velocity is steady.

    The record is split into runs of one direction with ``|v| > v_min`` (default 5 % of
    ``max |v|``); in each run, samples within ``max(abs_tol, rel_tol |median|)`` of the run's
    median velocity form candidate windows; the longest is kept if it lasts at least
    ``min_duration`` seconds, then ``trim`` of its length is cut at both ends (transients).
    """
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.shape != v.shape or t.ndim != 1:
        raise ValueError("t and v must be 1-D of equal length")
    if not (0.0 <= trim < 0.5):
        raise ValueError(f"trim must be in [0, 0.5), got {trim}")
    vmax = float(np.max(np.abs(v))) if v.size else 0.0
    if vmax == 0.0:
        return []
    thr = 0.05 * vmax if v_min is None else float(v_min)
    sgn = np.where(v > thr, 1, np.where(v < -thr, -1, 0))
    out: list[tuple[int, int]] = []
    i = 0
    n = v.size
    while i < n:
        if sgn[i] == 0:
            i += 1
            continue
        j = i
        while j < n and sgn[j] == sgn[i]:
            j += 1
        med = float(np.median(v[i:j]))
        ok = np.abs(v[i:j] - med) <= max(abs_tol, rel_tol * abs(med))
        best = None
        k = 0
        while k < ok.size:
            if not ok[k]:
                k += 1
                continue
            m = k
            while m < ok.size and ok[m]:
                m += 1
            if best is None or (m - k) > (best[1] - best[0]):
                best = (k, m)
            k = m
        if best is not None:
            a, b = i + best[0], i + best[1]
            if t[b - 1] - t[a] >= min_duration:
                cut = int(trim * (b - a))
                if b - cut - (a + cut) >= 3:
                    out.append((a + cut, b - cut))
        i = j
    return out


def constant_velocity_points(
    t: Any,
    force: Any,
    *,
    x: Any = None,
    v: Any = None,
    pressure: Any = None,
    smooth_time: float = 0.1,
    min_duration: float = 0.2,
    rel_tol: float = 0.15,
    abs_tol: float = 0.0,
    v_min: float | None = None,
    trim: float = 0.1,
    windows: Sequence[tuple[int, int]] | None = None,
) -> FrictionPoints:
    """Average force (and pressure) over steady-velocity windows of a record (004 sec. 3.2).

    Give the position ``x`` (preferred: the window velocity is then the slope of a line
    through the positions, immune to differentiation noise) or the velocity ``v``. Windows come
    from :func:`steady_windows` on ``v`` (or on the Savitzky-Golay velocity of ``x`` over
    ``smooth_time``) unless passed in. ``group`` numbers the windows in time order.
    """
    t = np.asarray(t, dtype=float)
    f = np.asarray(force, dtype=float)
    if x is None and v is None:
        raise ValueError("give the position x or the velocity v")
    if f.shape != t.shape:
        raise ValueError(f"force has shape {f.shape}, expected {t.shape}")
    xa = None if x is None else np.asarray(x, dtype=float)
    va = np.asarray(v, dtype=float) if v is not None else smoothed_velocity(t, xa, smooth_time)
    pa = None if pressure is None else np.asarray(pressure, dtype=float)
    if windows is None:
        windows = steady_windows(t, va, min_duration=min_duration, rel_tol=rel_tol,
                                 abs_tol=abs_tol, v_min=v_min, trim=trim)
    rows: dict[str, list[float]] = {k: [] for k in ("v", "f", "p", "fs", "n", "t0", "t1")}
    for i0, i1 in windows:
        sl = slice(i0, i1)
        if xa is not None:
            tt = t[sl] - t[sl].mean()
            vel = float(np.polyfit(tt, xa[sl], 1)[0])
        else:
            vel = float(va[sl].mean())
        rows["v"].append(vel)
        rows["f"].append(float(f[sl].mean()))
        rows["p"].append(float(pa[sl].mean()) if pa is not None else 0.0)
        rows["fs"].append(float(f[sl].std()))
        rows["n"].append(i1 - i0)
        rows["t0"].append(float(t[i0]))
        rows["t1"].append(float(t[i1 - 1]))
    if not rows["v"]:
        raise InsufficientDataError(
            f"no steady-velocity window of at least {min_duration} s found "
            f"(rel_tol {rel_tol}, smooth_time {smooth_time} s)"
        )
    return FrictionPoints(
        v=rows["v"], force=rows["f"], pressure=rows["p"] if pa is not None else None,
        force_std=rows["fs"], n_samples=rows["n"], t_start=rows["t0"], t_end=rows["t1"],
        group=np.arange(len(rows["v"])),
    )


def constant_velocity_test(
    simulate: Callable[[float], Mapping[str, Any]],
    commands: Sequence[float],
    *,
    area_a: float | None = None,
    area_b: float | None = None,
    settle_time: float = 0.0,
    min_duration: float = 0.2,
    rel_tol: float = 0.15,
    smooth_time: float = 0.05,
) -> FrictionPoints:
    """The constant-velocity friction test of 004 sec. 3.2 for any plant.

    For each valve command ``c`` in ``commands``, ``simulate(c)`` runs the plant (or the rig)
    with that command held and returns a mapping with ``"t"`` [s], ``"x"`` [m] or ``"v"`` [m/s],
    and either ``"force"`` [N] (the friction-balancing force) or ``"pa"``, ``"pb"`` [Pa] chamber
    pressures, turned into ``F_f = A_a p_a - A_b p_b`` (004 eq (1); ``area_b`` defaults to
    ``area_a``); an optional ``"pressure"`` entry is averaged too. Samples before
    ``settle_time`` are ignored; the longest steady window (:func:`steady_windows`) gives one
    point per command. Commands whose run never reaches a steady velocity are skipped; if none
    does, :class:`InsufficientDataError` is raised.
    """
    parts = []
    skipped = []
    for c in commands:
        rec = simulate(float(c))
        if "t" not in rec:
            raise KeyError("simulate() must return a mapping with 't'")
        t = np.asarray(rec["t"], dtype=float)
        if "force" in rec:
            f = np.asarray(rec["force"], dtype=float)
        elif "pa" in rec and "pb" in rec:
            if area_a is None:
                raise ValueError("area_a is required when simulate() returns pressures")
            f = chamber_force(rec["pa"], rec["pb"], area_a, area_a if area_b is None else area_b)
        else:
            raise KeyError("simulate() must return 'force' or both 'pa' and 'pb'")
        keep = t >= t[0] + settle_time
        kw: dict[str, Any] = {}
        for key in ("x", "v", "pressure"):
            if key in rec:
                kw[key] = np.asarray(rec[key], dtype=float)[keep]
        try:
            pts = constant_velocity_points(t[keep], f[keep], smooth_time=smooth_time,
                                           min_duration=min_duration, rel_tol=rel_tol, **kw)
        except InsufficientDataError:
            skipped.append(c)
            continue
        best = int(np.argmax(pts.n_samples))
        one = pts.select([best])
        one.command = np.array([float(c)])
        parts.append(one)
    if not parts:
        raise InsufficientDataError(
            f"no command reached a steady velocity (commands {list(commands)}); lengthen the "
            "runs or relax rel_tol"
        )
    out = FrictionPoints.concatenate(parts)
    out.group = np.arange(len(out))
    out.meta = {"source": "004 sec. 3.2 constant-velocity test", "skipped_commands": skipped}
    return out


# ======================================================================================
# excitation signals
# ======================================================================================


# ======================================================================================
# measured seal friction (CC0): EvaZillen/3D-printed-pneumatic-actuator
# ======================================================================================

SEAL_FRICTION_PLANT = "seal_friction"
#: X-ring test cylinder bore [m] (data README: "Bore 25.7 mm for these X-ring files")
SEAL_BORE = 0.0257

_RAW_COLUMNS = ("time [ms]", "laser signal [V]", "pressure signal [V]", "force signal [V]",
                "displacement [mm]", "pressure [bar gauge]", "load-cell force [N]")
_RAW_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def _parse_raw_seal(path: Path, text: str) -> tuple[np.ndarray, list[int]]:
    rows = []
    linenos = []
    for k, ln in enumerate(text.splitlines()):
        s = ln.strip()
        if not s:
            continue
        cells = s.split()
        if len(cells) != 7:
            raise MeasuredDataError(
                path,
                f"line {k + 1}: has {len(cells)} whitespace-separated values, expected 7 "
                f"({', '.join(_RAW_COLUMNS)})",
                line=k + 1,
            )
        row = []
        for j, c in enumerate(cells):
            if not _RAW_NUMBER.fullmatch(c):
                raise MeasuredDataError(
                    path, f"line {k + 1}, column {j + 1} ({_RAW_COLUMNS[j]}): {c!r} is not a "
                    "finite decimal number", line=k + 1, column=_RAW_COLUMNS[j])
            row.append(float(c))
        rows.append(row)
        linenos.append(k + 1)
    return np.array(rows, dtype=float).reshape(-1, 7), linenos


def load_seal_friction(
    path: str | os.PathLike[str],
    *,
    bore: float | None = SEAL_BORE,
    drop_rows: int = 15,
) -> MeasuredData:
    """Load a seal-friction record as plant ``seal_friction`` (channels ``x, p_gauge, F_load``, SI).

    Two formats are accepted:

    * the original files (whitespace-separated, no header, about 100 Hz, seven columns: time
      [ms], laser / pressure / force sensor signals [V], displacement [mm], chamber pressure
      [bar, gauge], load-cell force [N]; see ``tests/data/pneumatic_seal_friction/README.md``).
      The first ``drop_rows`` rows are dropped, as in the original analysis; time is converted
      to s (starting at the first kept row's time), mm to m, bar to Pa. The raw sensor voltages
      are not kept.
    * a measured-data CSV (:mod:`hydro_envs.data.measured`) with ``# plant: seal_friction``.

    The format is recognised by the first non-blank character (``#`` or a letter: measured-data
    CSV; a digit or sign: original). Malformed files raise
    :class:`~hydro_envs.data.measured.MeasuredDataError` naming file, line and column. The
    piston area ``pi bore^2 / 4`` is stored as ``metadata["piston_area"]`` (CSV files may carry
    their own). ``bore=None``: no geometry is assumed; an original-format file then carries no
    ``piston_area`` and :func:`seal_friction_points` needs ``piston_area``.

    The logger's clock is irregular (10-17 ms steps, pauses); the record is kept as sampled --
    the stroke analysis (:func:`seal_friction_points`) fits each window on its own time stamps
    and needs no uniform clock.
    """
    p = Path(path)
    if not p.is_file():
        raise MeasuredDataError(p, "file not found")
    if bore is not None and not (math.isfinite(bore) and bore > 0):
        raise ValueError(f"bore = {bore!r} m; allowed: a finite value > 0 m")
    raw = p.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise MeasuredDataError(p, f"not valid UTF-8 (byte offset {e.start})") from None
    first = text.lstrip()[:1]
    if not first:
        raise MeasuredDataError(p, "file is empty")
    area = None if bore is None else math.pi * bore**2 / 4.0
    if first == "#" or first.isalpha():
        data = load_measured(p, plant=SEAL_FRICTION_PLANT)
        if area is not None:
            data.metadata.setdefault("piston_area", repr(area))
        return data
    arr, linenos = _parse_raw_seal(p, text)
    if drop_rows < 0:
        raise ValueError(f"drop_rows must be >= 0, got {drop_rows}")
    arr = arr[drop_rows:]
    linenos = linenos[drop_rows:]
    if arr.shape[0] < 2:
        raise MeasuredDataError(p, f"has {arr.shape[0]} data row(s) after dropping {drop_rows}; "
                                "at least 2 are needed")
    t_ms = arr[:, 0]
    bad = np.flatnonzero(~(np.diff(t_ms) > 0))
    if bad.size:
        i = int(bad[0]) + 1
        raise MeasuredDataError(
            p, f"line {linenos[i]}, column 1 (time [ms]): time {t_ms[i]!r} is not greater than "
            f"{t_ms[i - 1]!r} on line {linenos[i - 1]}; time must be strictly increasing",
            line=linenos[i], column="time [ms]")
    t = (t_ms - t_ms[0]) * 1e-3
    return MeasuredData(
        plant=SEAL_FRICTION_PLANT,
        t=t,
        channels={"x": arr[:, 4] * 1e-3, "p_gauge": arr[:, 5] * 1e5, "F_load": arr[:, 6]},
        units={"t": "s", "x": "m", "p_gauge": "Pa", "F_load": "N"},
        metadata={
            "source": f"{p.name}: EvaZillen/3D-printed-pneumatic-actuator, "
                      "results_pneumatic-actuator/data/friction (CC0 1.0)",
            "license": "CC0-1.0",
            "dropped_rows": str(drop_rows),
            "t0_ms": repr(float(t_ms[0])),
            **({} if bore is None else {"bore": repr(bore), "piston_area": repr(area)}),
        },
    )


def seal_friction_points(
    data: MeasuredData,
    *,
    piston_area: float | None = None,
    smooth_time: float = 0.3,
    min_duration: float = 0.5,
    rel_tol: float = 0.25,
    trim: float = 0.15,
) -> FrictionPoints:
    """One friction point per constant-speed stroke of a seal-friction record.

    Friction ``F_f = F_load - p_gauge A`` -- the README's ``p A - F_loadcell`` with the sign
    flipped so that it follows the direction of ``v = dx/dt`` of the displacement column
    (friction opposes the motion: ``F_f v > 0``, checked in the tests). The windows are the
    steady parts of each stroke (:func:`steady_windows` on the Savitzky-Golay velocity over
    ``smooth_time``); velocity = slope of the positions, pressure = mean ``p_gauge``;
    ``group`` numbers the strokes.
    """
    for ch in ("x", "p_gauge", "F_load"):
        if ch not in data:
            raise MeasuredDataError(None, f"seal-friction data need channel {ch!r}", column=ch)
    if piston_area is None:
        if "piston_area" not in data.metadata:
            raise ValueError("piston_area is unknown: the record carries no 'piston_area' "
                             "(give the bore or the piston area)")
        piston_area = float(data.metadata["piston_area"])
    f = data["F_load"] - data["p_gauge"] * piston_area
    pts = constant_velocity_points(
        data.t, f, x=data["x"], pressure=data["p_gauge"], smooth_time=smooth_time,
        min_duration=min_duration, rel_tol=rel_tol, trim=trim,
    )
    pts.meta = {"piston_area": piston_area, "source": data.metadata.get("source", "")}
    return pts


# ======================================================================================
# 000 methods 1 and 2: viscous coefficient of the compensator spool from two-pressure data
# ======================================================================================


def fit_compensator_viscous(result: Any, params: Any = None, *, sampling: bool = True,
                            bounds: tuple[float, float] = (0.05, 100.0)) -> float:
    """Viscous coefficient ``c`` [N s/m] at the test temperature from a virtual-rig Bode
    measurement of 000, method 1 (``p2/p1``, :class:`hydro_envs.plants.ls_compensator.experiments.Method1Result`)
    or method 2 (eq (18) ``p_I/p_P``, ``Method2Result``, every row with its own mean pressure
    and orifice).

    The model is the kernel right-hand side linearised about each row's operating point
    (:func:`hydro_envs.plants.ls_compensator.linearize`), ``H(s) = e_k' (sI - A)^-1 B``
    with ``k`` = p2 (method 1) or p_out (method 2); ``c`` minimises
    ``sum |H_model - H_measured|^2`` (bounded scalar search on log c).

    *Sampling* (``sampling=True``): the rigs drive the plant with the first-order-hold
    (piecewise-linear) interpolant of the sampled inlet pressure, while the ratio divides by
    the first harmonic of the samples. The interpolant of a sampled sine has the first
    harmonic ``sinc^2(f T)`` times the sine's, in phase (the triangular FOH kernel is
    symmetric), so the measured ratio is ``sinc^2(f T) H(j w)`` and the model is multiplied by
    it. At 300 Hz / 20 kHz that is 0.07 %; it matters at high frequency or slow sampling.
    ``params``: model of everything else (default: the rig's own plant per row).
    """
    import dataclasses

    from scipy.optimize import minimize_scalar

    from hydro_envs.plants.ls_compensator import model as lc

    freq = np.asarray(result.frequency, dtype=float)
    ratio = np.asarray(result.ratio, dtype=complex)
    if hasattr(result, "mean_gauge"):  # method 2
        plants = list(result.params) if params is None else [params] * freq.size
        p_in = 1.0e5 + np.asarray(result.mean_gauge, dtype=float)
        out_index = lc.PO
        fs = 20e3 if not hasattr(result, "sample_rate") else float(result.sample_rate)
    else:
        plants = [result.params if params is None else params] * freq.size
        p_in = np.full(freq.size, 1.0e5 + lc.METHOD1_MEAN_GAUGE)
        out_index = lc.P2
        fs = 10e3 if not hasattr(result, "sample_rate") else float(result.sample_rate)
    corr = np.sinc(freq / fs) ** 2 if sampling else np.ones(freq.size)
    # group the rows by (plant, operating point): one linearisation per group and c
    groups: dict[tuple[int, float], list[int]] = {}
    uniq: list[Any] = []
    for i, (q, pi) in enumerate(zip(plants, p_in)):
        for j, u in enumerate(uniq):
            if u == q:
                break
        else:
            uniq.append(q)
            j = len(uniq) - 1
        groups.setdefault((j, float(pi)), []).append(i)

    def model_ratio(c_t: float) -> np.ndarray:
        h = np.empty(freq.size, dtype=complex)
        for (j, pi), idx in groups.items():
            q = uniq[j]
            d = lc.derived(q)
            nu_ratio = d["viscous"] / max(q.viscous_friction_40c + q.lvdt_friction_40c, 1e-300)
            if not math.isfinite(nu_ratio) or nu_ratio <= 0:
                nu_ratio = 1.0
            qc = dataclasses.replace(q, viscous_friction_40c=c_t / nu_ratio, lvdt_friction_40c=0.0)
            A, B = lc.linearize(qc, pi)
            n = A.shape[0]
            for i in idx:
                s = 2j * math.pi * freq[i]
                h[i] = np.linalg.solve(s * np.eye(n) - A, B)[out_index] * corr[i]
        return h

    def cost(log_c: float) -> float:
        return float(np.sum(np.abs(model_ratio(math.exp(log_c)) - ratio) ** 2))

    r = minimize_scalar(cost, bounds=(math.log(bounds[0]), math.log(bounds[1])), method="bounded",
                        options={"xatol": 1e-5})
    return float(math.exp(r.x))


# ======================================================================================
# 004 sec. 4.2 closed-loop direct identification; 001 sec. 4.5 locked-piston PRBS
# ======================================================================================


def rodless_closed_loop_m_sequence(
    params: Any = None,
    *,
    dt: float = 0.01,
    kp: float = 50.0,
    n_bits: int = 10,
    amplitude: float = 0.3,
    samples_per_bit: int = 1,
    periods: int = 2,
    position_noise_std: float = 0.0,
    seed: int | None = 0,
) -> dict[str, np.ndarray]:
    """004 sec. 4.2 on the rodless cylinder: a proportional position loop holds the slider at
    mid-stroke, ``u = u_c + kp (r - y_m) + m(t)`` with the M-sequence ``m`` (``+-amplitude`` V,
    ``2**n_bits - 1`` bits of ``samples_per_bit`` samples, ``periods`` times) added to the
    controller output ("the input signal is the superposition of the controller output signal
    and M-sequence signal"); ``u`` is clipped to 0..command_max and held over ``dt``.

    Returns ``t, u`` [V] (the valve command, the ARX input), ``y`` [m] (measured position,
    the ARX output; white noise ``position_noise_std`` from ``default_rng(seed)``), ``y_true``
    and ``m``. The sample time of eq (32) is not printed; 10 ms (the default) puts our
    plant's 25 Hz mid-stroke resonance at the angle of eq (32)'s complex pair (1.2 rad,
    i.e. about 20 Hz at 10 ms). ``y[k]`` is sampled before ``u[k]`` is applied, so the loop
    has the one-sample delay direct identification needs (arx module docstring).
    """
    from hydro_envs.plants.rodless_cylinder import model as rc

    kernels = registry.get("rodless_cylinder").kernels
    p = params if params is not None else rc.RodlessCylinderParams()
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
    y_true = np.empty(n)
    for k in range(n):
        y_true[k] = Y[0, rc.Y]
        u[k] = min(max(p.command_centre + kp * (ref - (y_true[k] + noise[k])) + m[k], 0.0), p.command_max)
        U[0, 0] = u[k]
        kernels.step_serial(Y, U, P, dt, nsub, W, clamps)
    return {"t": np.arange(n) * dt, "u": u, "y": y_true + noise, "y_true": y_true, "m": m,
            "clamps": np.array(int(clamps[0]))}


def force_actuator_prbs_locked(
    params: Any = None,
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
    import dataclasses

    from hydro_envs.plants.force_actuator import model as fa

    p = params if params is not None else fa.ForceActuatorParams()
    p = dataclasses.replace(p, piston_locked=1.0)
    dt = fa.SEED_T
    t, i = prbs(duration, dt, clock_period=clock_samples * dt, amplitude=amplitude * p.rated_current, seed=seed)
    clamps = np.zeros(1, dtype=np.int64)
    states = simulate(registry.get("force_actuator"), p, i.reshape(-1, 1), fa.rest_state(p), dt, clamps=clamps)
    f = p.sensor_stiffness * states[1:, fa.XS]
    rng = np.random.default_rng(None if seed is None else seed + 1)
    noise = force_noise_std * rng.standard_normal(f.size) if force_noise_std > 0 else 0.0
    return {"t": t, "i": i, "f": f + noise, "f_true": f, "clamps": np.array(int(clamps[0]))}
