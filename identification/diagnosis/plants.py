r"""What the diagnosis workflow needs to know about each plant.

A :class:`DiagnosisPlant` names the plant's parameter dataclass, its input and
measured channels (:mod:`hydro_envs.data.channels` names), the *base-fit* parameters that are
calibrated in every model (quantities every rig needs calibrated whatever effects it has:
mass, viscous damping, oil stiffness, valve gain), how to estimate the full state at the
start of a record segment from the measured channels (unmeasured states at their quasi-static
values), realistic sensor noise, and the closed-loop experiment the hidden-effect tests and the
demo record (a position loop around the plant tracking a multisine plus slow ramps, so the
record covers both directions, low and high speed and several pressure levels without
reaching the end stops).

Sensor offsets: pressure channels (``sensor_offsets``) may carry an unknown constant offset --
a transducer's zero error of 0.1-0.5 % of full scale is 0.25-1.2 bar on a 250-bar sensor, as
large as a leakage's pressure sag, and a common-mode offset on both chamber pressures looks
like external leakage. The workflow proposes "sensor_offsets" (one constant per channel,
profiled out of the refit: identification.greybox ``offsets``) as a measuring-chain candidate
beside the catalogue's effects; when it wins on held-out data it is kept as a correction,
flagged, and the search for physical effects goes on. Estimating offsets in every fit instead
was tried and rejected: they absorb the constant part of real effects (hidden servo friction
asymmetry: held-out shrink 0.78 -> 0.28).

Two comparison choices are per plant and physical: ``offset_free`` channels (positions of
integrating plants) are compared without their per-window mean -- a window replayed open-loop
from an estimated start velocity carries a constant position offset that is a start-state
error, not a model error; and held-out scores low-pass the error at ``score_bandwidth``
(the band of the test motion and of the position loop: 50 Hz for the cylinders and the slider,
the excitation band for the open-loop rigs), so white sensor noise above it does not set the
floor of the score.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
import numpy as np

from hydro_envs.params import PhysicalParams

__all__ = ["DiagnosisPlant", "PLANTS", "diagnosis_plant", "reference_signal"]


@dataclasses.dataclass(frozen=True)
class DiagnosisPlant:
    """Plant description for the diagnosis workflow (see the module docstring)."""

    name: str
    params_factory: Callable[[], PhysicalParams]  # nominal parameters
    n_states: int
    inputs: tuple[str, ...]
    outputs: Mapping[str, int | Callable[[np.ndarray, np.ndarray], np.ndarray]]  # channel -> state index
    # or function (states (c, T, n_states), params (c, n_params)) -> (c, T)
    derivative_outputs: Mapping[str, int]  # measured channel -> derivative of state index
    required: tuple[str, ...]  # channels a record must have
    base_fit: tuple[str, ...]
    noise: Mapping[str, float]  # realistic sensor noise (std) per channel, synthetic data
    initial_state: Callable[[PhysicalParams, Mapping[str, float]], np.ndarray]
    controller: Callable[[np.ndarray, float, PhysicalParams], float]  # (meas, ref) -> input
    position_channel: str
    reference_centre: Callable[[PhysicalParams], float]  # m, centre of the test motion
    reference_amplitude: float  # m
    reference_speed: float  # m/s, ramp speed of the slow passes
    segment_seconds: float
    # unscored start of every window: >= ~3 time constants of the slowest lightly damped mode
    # the start-state estimate excites (slider m/b = 50 ms; servo oil column 1/(zeta_h omega_h)
    # = 0.1 s; shaking-table oil column ~0.18 s; rodless: friction-damped air spring), so the
    # scored part sees the model, not the start transient (truth-model floor of the table's
    # held-out NRMSE: 0.05 with 0.1 s, 0.0015 with 0.3 s, measured)
    warmup_seconds: float
    position_state: int
    velocity_state: int
    score_bandwidth: float  # Hz: held-out scores low-pass the error here (sensor noise above is not model error)
    offset_free: tuple[str, ...] = ()  # channels compared without their per-window mean (integrating outputs)
    # channels with an unknown constant sensor offset per record (pressure transducers' zero
    # error, 0.1-0.5 % of full scale): a nuisance parameter of every fit and score
    sensor_offsets: tuple[str, ...] = ()
    kernel_inputs: int = 1  # width of the kernel's input vector (extra columns held at 0)
    reference: Callable[[np.ndarray, np.random.Generator], np.ndarray] | None = None  # test signal override
    sample_time: float = 1e-3  # s, of the synthetic test records (the plant's control period)

    @property
    def params_cls(self) -> type:
        return type(self.params_factory())


def reference_signal(t: np.ndarray, amplitude: float, speed: float, rng: np.random.Generator) -> np.ndarray:
    """Position reference [m]: slow triangle passes (constant speed ``speed`` and ``speed/4``,
    both directions) plus a random-phase multisine of 0.3-8 Hz, zero mean, peak <= amplitude.

    The ramps give long constant-velocity passes (where friction levels show), the multisine
    the dynamics (oil spring, valve) and many velocity reversals."""
    t = np.asarray(t, dtype=float)
    dur = float(t[-1] - t[0]) if t.size > 1 else 1.0
    a_tri = 0.45 * amplitude
    slow = np.zeros_like(t)
    half = dur / 2
    for k, (sp, sl) in enumerate(((speed, slice(None)), (speed / 4, slice(None)))):
        period = 4 * a_tri / sp
        phase = (t - t[0]) / period + rng.uniform()
        tri = a_tri * (2 * np.abs(2 * (phase - np.floor(phase + 0.5))) - 1)
        mask = (t - t[0] < half) if k == 0 else (t - t[0] >= half)
        slow[mask] = tri[mask]
    freqs = np.array([0.3, 0.7, 1.3, 2.1, 3.4, 5.5, 8.0])
    amps = 0.2 * amplitude / (1 + freqs)
    ph = rng.uniform(0, 2 * np.pi, freqs.size)
    ms = (amps[None, :] * np.sin(2 * np.pi * freqs[None, :] * (t - t[0])[:, None] + ph[None, :])).sum(axis=1)
    return slow + ms


def _multisine(f_lo: float, f_hi: float, n: int):
    """Reference generator: a random-phase multisine of ``n`` log-spaced frequencies from
    ``f_lo`` to ``f_hi`` Hz, peak-normalised to 1."""
    def reference(t, rng):
        f = np.geomspace(f_lo, f_hi, n)
        ph = rng.uniform(0, 2 * np.pi, f.size)
        sig = np.sin(2 * np.pi * f[None, :] * (t - t[0])[:, None] + ph[None, :]).sum(axis=1)
        return sig / np.max(np.abs(sig))
    return reference


# ------------------------------------------------------------------------------- slider
def _slider() -> DiagnosisPlant:
    from hydro_envs.plants.slider import model as sl

    def init(params, m):
        return np.array([m["x"], m.get("v", 0.0)])

    def controller(meas, ref, params):
        # PD position loop, 40 rad/s bandwidth for the 1 kg stage, clipped to force_max
        e = ref[0] - meas["x"]
        f = params.mass * (40.0**2 * e + 2 * 0.7 * 40.0 * (ref[1] - meas["v"]))
        return float(np.clip(f, -params.force_max, params.force_max))

    return DiagnosisPlant(
        name="slider", params_factory=sl.SliderParams, n_states=sl.N_STATES,
        inputs=("f",), outputs={"x": sl.X}, derivative_outputs={}, required=("f", "x"),
        base_fit=("mass", "viscous_friction"),
        # 1 um encoder, 0.02 N load cell
        noise={"x": 1e-6, "f": 0.02},
        initial_state=init, controller=controller, position_channel="x",
        reference_centre=lambda p: 0.5 * p.stroke, reference_amplitude=0.06, reference_speed=0.05, segment_seconds=1.0, warmup_seconds=0.15,
        position_state=sl.X, velocity_state=sl.V, score_bandwidth=50.0, offset_free=("x",),
    )


# ------------------------------------------------------------------------------- servo
def _servo() -> DiagnosisPlant:
    from hydro_envs.plants.servo_cylinder import model as sc

    def init(params, m):
        y = np.zeros(sc.N_STATES)
        pm = 0.5 * (params.supply_pressure + params.tank_pressure)
        y[sc.X] = m["x"]
        y[sc.V] = m.get("v", 0.0)
        y[sc.P1] = m.get("p1", pm)
        y[sc.P2] = m.get("p2", pm)
        y[sc.XV] = float(np.clip(params.spool_gain * m.get("u", 0.0), -params.spool_stroke, params.spool_stroke))
        return y

    def controller(meas, ref, params):
        # P position loop with velocity feedforward, K_v = 40 1/s (the demo's gain)
        kq = sc.no_load_velocity(params) / params.command_max  # m/s per V
        u = (40.0 * (ref[0] - meas["x"]) + ref[1]) / kq
        return float(np.clip(u, -params.command_max, params.command_max))

    return DiagnosisPlant(
        name="servo_cylinder", params_factory=sc.ServoCylinderParams, n_states=sc.N_STATES, inputs=("u",), outputs={"x": sc.X, "p1": sc.P1, "p2": sc.P2},
        derivative_outputs={}, required=("u", "x"),
        base_fit=("viscous_friction", "bulk_modulus", "discharge_coefficient"),
        # 1 um encoder (quantisation + electronics), 0.05 bar filtered pressure transducer
        noise={"x": 1e-6, "p1": 5e3, "p2": 5e3, "u": 0.0},
        initial_state=init, controller=controller, position_channel="x",
        reference_centre=lambda p: 0.5 * p.stroke, reference_amplitude=0.025, reference_speed=0.02, segment_seconds=0.7, warmup_seconds=0.3,
        position_state=sc.X, velocity_state=sc.V, score_bandwidth=50.0, offset_free=("x",),
        sensor_offsets=("p1", "p2"),
    )


# ------------------------------------------------------------------------------- shaking table
def _shaking_table() -> DiagnosisPlant:
    from hydro_envs.plants.shaking_table import model as st

    def init(params, m):
        y = st.rest_state(params, m["x"], m.get("v", 0.0))
        y[st.PA] = m.get("pa", y[st.PA])
        y[st.PB] = m.get("pb", y[st.PB])
        y[st.XV] = float(np.clip(params.spool_gain * m.get("u", 0.0), -1.0, 1.0))
        return y

    def controller(meas, ref, params):
        # P position loop with velocity feedforward through the no-load valve gain; K_v = 6 1/s
        # stays below the oil column's 2 zeta_h omega_h (~10 1/s: omega_h = 54 rad/s at 200 kg,
        # zeta_h ~ 0.1), 25 1/s made the loop limit-cycle at full valve opening
        kq = st.no_load_velocity(params) / params.command_max  # m/s per V
        u = (6.0 * (ref[0] - meas["x"]) + ref[1]) / kq
        return float(np.clip(u, -params.command_max, params.command_max))

    return DiagnosisPlant(
        name="shaking_table", params_factory=st.ShakingTableParams, n_states=st.N_STATES, inputs=("u",), outputs={"x": st.X, "pa": st.PA, "pb": st.PB},
        derivative_outputs={"a": st.V},
        required=("u", "x"),
        base_fit=("e0", "flow_coefficient"),  # viscous friction stays at 003 Table 2 (429.4 N s/m)
        # 16-bit potentiometer over 300 mm (4.6 um step), ADXL05-class accelerometer,
        # 0.05 bar filtered pressure transducers (optional channels: 003 measured x and a only)
        noise={"x": 2e-6, "a": 0.02, "pa": 5e3, "pb": 5e3, "u": 0.0},
        initial_state=init, controller=controller, position_channel="x",
        reference_centre=lambda p: 0.0, reference_amplitude=0.05, reference_speed=0.08, segment_seconds=0.8, warmup_seconds=0.3,
        position_state=st.X, velocity_state=st.V, score_bandwidth=50.0, offset_free=("x",),
        sensor_offsets=("pa", "pb"),
    )


# ------------------------------------------------------------------------------- rodless (004)
def _rodless() -> DiagnosisPlant:
    from hydro_envs.plants.rodless_cylinder import model as rc

    def init(params, m):
        y = rc.rest_state(params, m["y"], m.get("v", 0.0), m.get("pa"), m.get("pb"))
        du = m.get("u", params.command_centre) - params.command_centre
        y[rc.XV] = float(np.clip(du / (params.command_max - params.command_centre) * params.spool_stroke,
                                 -params.spool_stroke, params.spool_stroke))
        return y

    def controller(meas, ref, params):
        # P position loop around the 5 V centre (004 sec. 4.2 uses kp = 50 V/m) with velocity
        # feedforward through the valve's no-load speed gain (~0.3 m/s per V at 6 bar)
        u = params.command_centre + 150.0 * (ref[0] - meas["x"]) + ref[1] / 0.3
        return float(np.clip(u, 0.0, params.command_max))

    return DiagnosisPlant(
        name="rodless_cylinder", params_factory=rc.RodlessCylinderParams, n_states=rc.N_STATES, inputs=("u",), outputs={"y": rc.Y, "pa": rc.PA, "pb": rc.PB},
        derivative_outputs={}, required=("u", "y"),
        base_fit=("viscous_friction", "discharge_coefficient"),
        # 1 um encoder, 0.5 kPa (5 mbar) pressure transducers of a 10-bar range
        noise={"y": 1e-6, "pa": 500.0, "pb": 500.0, "u": 0.0},
        initial_state=init, controller=controller, position_channel="y",
        reference_centre=lambda p: 0.5 * p.stroke, reference_amplitude=0.035, reference_speed=0.02,
        segment_seconds=0.7, warmup_seconds=0.3, position_state=rc.Y, velocity_state=rc.V,
        score_bandwidth=50.0, offset_free=("y",), sensor_offsets=("pa", "pb"),
    )


# ------------------------------------------------------------------------------- LS compensator (000)
def _ls_compensator() -> DiagnosisPlant:
    from hydro_envs.plants.ls_compensator import model as lc

    def init(params, m):
        y = np.zeros(lc.N_STATES)
        eq = lc.equilibrium_state(params, m.get("u", 7e5))
        y[: eq.size] = eq
        y[lc.X] = m["x"]
        y[lc.V] = m.get("v", 0.0)
        if "p2" in m:
            y[lc.P2] = m["p2"]
        return y

    def controller(meas, ref, params):
        # 000 method 1: the pilot-line inlet pressure oscillates around ~6 bar gauge (3-9 bar);
        # open loop here: a multisine of +-1.5 bar around 6 bar gauge (the spool stays off its
        # seat and off the travel limit)
        return 7e5 + 1.5e5 * ref[0]

    # random-phase multisine 5-400 Hz (covers omega_1 = 67 Hz, omega_m = 108 Hz,
    # omega_h = 453 Hz of 000 Table 1)
    reference = _multisine(5.0, 400.0, 24)

    return DiagnosisPlant(
        name="ls_compensator", params_factory=lc.LSCompensatorParams, n_states=lc.N_STATES, inputs=("p1",), outputs={"x": lc.X, "p2": lc.P2}, derivative_outputs={},
        required=("p1", "x"), base_fit=("spring_stiffness", "bulk_modulus"),
        # LVDT 0.1 um electronics noise on a +-2 mm range; 1 kPa pressure transducer
        noise={"x": 1e-7, "p2": 1e3, "p1": 0.0},
        initial_state=init, controller=controller, position_channel="x",
        reference_centre=lambda p: lc.operating_point(p, 7e5), reference_amplitude=1.0, reference_speed=1.0,
        segment_seconds=0.25, warmup_seconds=0.05, position_state=lc.X, velocity_state=lc.V,
        score_bandwidth=400.0, kernel_inputs=2, reference=reference, sample_time=2e-4, sensor_offsets=("p2",),
    )


# ------------------------------------------------------------------------------- force actuator rigs: shared
def _fa_sensed_force(S, P):
    """Sensed force of 001 eq (3), F_s = k_s x_s (output function of both force-actuator rigs)."""
    from hydro_envs.plants.force_actuator import model as fa

    return P[:, fa.I_KS, None] * S[:, :, fa.XS]


def _fa_open_loop(meas, ref, p):
    """Open-loop valve current: +-50 % of the rated current times the reference."""
    return 0.5 * p.rated_current * ref[0]


# ------------------------------------------------------------------------------- force actuator (001)
def _force_actuator() -> DiagnosisPlant:
    from hydro_envs.plants.force_actuator import model as fa

    def params():
        # the blocked-piston rig of 001 sec. 4 (piston locked at mid-stroke), where the seed
        # identified the valve and the sensor; eq (5)'s damping needs a moving piston:
        # force_actuator_load below
        return fa.ForceActuatorParams()

    def init(p, m):
        y = fa.rest_state(p)
        y[fa.XS] = m.get("f", 0.0) / p.sensor_stiffness
        return y

    # random-phase multisine 2-150 Hz (below eq (8)'s resonances)
    reference = _multisine(2.0, 150.0, 16)

    return DiagnosisPlant(
        name="force_actuator", params_factory=params, n_states=fa.N_STATES,
        inputs=("i",), outputs={"f": _fa_sensed_force}, derivative_outputs={}, required=("i", "f"),
        base_fit=("sensor_damping", "valve_offset"),
        noise={"f": 2.0, "i": 0.0},  # 0.15 % of the 1340 N range
        initial_state=init, controller=_fa_open_loop, position_channel="f",
        reference_centre=lambda p: 0.0, reference_amplitude=1.0, reference_speed=1.0,
        segment_seconds=0.2, warmup_seconds=0.04, position_state=fa.XS, velocity_state=fa.VS,
        score_bandwidth=300.0, reference=reference, sample_time=2e-4,
    )


# ------------------------------------------------------------------------------- force actuator, moving piston
def _force_actuator_load() -> DiagnosisPlant:
    from hydro_envs.plants.force_actuator import model as fa

    def params():
        # 001's actuator driving a load: the piston free, pushing a 5 kg payload against a
        # 50 kN/m spring (a compliant environment, 16 Hz; full thrust deflects it 27 mm, inside
        # the +-38 mm half stroke, so the stops are never reached). Only here do the piston
        # velocity and so eq (5)'s hydraulic damping show in the sensed force. Friction: the
        # static curve (friction_model = 1, smooth Coulomb F_c = 26 N of eq (1), stiction at
        # the Coulomb level), the realisation every diagnosis base model uses; eq (1)'s Dahl
        # state would relax at 4 sigma0 v_b / F_c = 1.7e5 1/s at the free piston's speed bound
        # (16 sub-steps per 0.2 ms instead of 2)
        return fa.ForceActuatorParams(piston_locked=0.0, load_mass=5.0, load_stiffness=5e4, friction_model=1.0,
                                      stiction_retract=26.0, stiction_extend=26.0)

    def init(p, m):
        # sensor deflection from the measured force; the piston at its quasi-static position on
        # the load spring (sensed force ~ spring force below the 16 Hz load mode), velocity
        # from the force's rate; valve and fluid states at rest (covered by the warm-up)
        y = fa.rest_state(p)
        f = m.get("f", 0.0)
        y[fa.XS] = f / p.sensor_stiffness
        if p.load_stiffness > 0:
            y[fa.XP] = 0.5 * p.stroke + f / p.load_stiffness
            y[fa.VP] = m.get("v", 0.0) / p.load_stiffness
            y[fa.VF] = y[fa.VP]
        return y

    # random-phase multisine 1-60 Hz: drives the load through its 16 Hz mode at piston
    # speeds up to and past eq (5)'s knee velocities
    reference = _multisine(1.0, 60.0, 14)

    return DiagnosisPlant(
        name="force_actuator_load", params_factory=params, n_states=fa.N_STATES,
        inputs=("i",), outputs={"f": _fa_sensed_force}, derivative_outputs={}, required=("i", "f"),
        # damping_linear: eq (5)'s linear term c v -- the viscous damping every moving-piston
        # model has (like the cylinders' viscous friction), so it is calibrated in the base
        base_fit=("valve_offset", "damping_linear", "load_stiffness"),
        noise={"f": 2.0, "i": 0.0},  # 0.15 % of the 1340 N range
        initial_state=init, controller=_fa_open_loop, position_channel="f",
        reference_centre=lambda p: 0.0, reference_amplitude=1.0, reference_speed=1.0,
        # warm-up: the load's slow (overdamped) mode k_L / (0.4 c) = 31 ms, x 3, plus the valve
        segment_seconds=0.3, warmup_seconds=0.12, position_state=fa.XS, velocity_state=fa.VS,
        score_bandwidth=100.0, reference=reference, sample_time=2e-4,
    )


_FACTORIES: dict[str, Callable[[], DiagnosisPlant]] = {
    "slider": _slider,
    "servo_cylinder": _servo,
    "shaking_table": _shaking_table,
    "rodless_cylinder": _rodless,
    "ls_compensator": _ls_compensator,
    "force_actuator": _force_actuator,
    "force_actuator_load": _force_actuator_load,
}
PLANTS = tuple(_FACTORIES)
_CACHE: dict[str, DiagnosisPlant] = {}


def diagnosis_plant(name: str) -> DiagnosisPlant:
    """The :class:`DiagnosisPlant` of ``name`` (clear error listing the supported plants)."""
    if name not in _FACTORIES:
        raise KeyError(f"diagnosis: plant {name!r} not supported; supported: {sorted(_FACTORIES)}")
    if name not in _CACHE:
        _CACHE[name] = _FACTORIES[name]()
    return _CACHE[name]

