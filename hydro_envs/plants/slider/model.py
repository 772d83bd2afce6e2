r"""Generic slider: a mass with Stribeck friction and a constant force, driven by a force.

Plant id 6 (``SLIDER`` in :mod:`hydro_envs.sim.kernels`). This is the identification and
diagnosis plant for any positioning stage that is measured with a force sensor (or a
calibrated actuator force: motor current times force constant, pressure difference times
area) and a position sensor. It has no environment; :func:`simulate_slider` rolls it out
on the batched kernel and :mod:`identification.slider` identifies its parameters from
``(force, position)`` records.

State (SI)::

    index  name  unit  meaning
    0      x     m     position of the measured body, 0 at the lower end stop, ``stroke`` at the upper one
    1      v     m/s   its velocity
    2      xd    m     position of the driven body (= x for a rigid drive)
    3      vd    m/s   its velocity

Input: ``u[0] = f`` [N], the applied force (positive towards +x), acting on the driven body.

Equations, rigid drive (``backlash_gap = 0``, the default; x_d, v_d follow x, v)::

    x' = v
    m v' = f - F_0 - F_f(v) + F_stop(x, v)
    F_f(v) = (F_C + (F_S - F_C) exp(-|v| / v_S)) tanh(v / v_eps) + b v     (002 eq (1))

With a play of ``+-g`` between the driven body (mass ``(1 - mu) m``) and the measured load
(``mu m``), each carrying its share of F_0 and of the friction::

    mu m v'        = F_c - mu F_0 - mu F_f(v) + F_stop(x, v)
    (1 - mu) m v_d' = f - (1 - mu) F_0 - (1 - mu) F_f(v_d) - F_c
    F_c = backlash_force(x_d - x, v_d - v, g, k_c, alpha_c)   (dead zone, Hunt-Crossley contact)

``F_0`` is a constant force opposing +x: gravity on an inclined stage, cable-chain drag, or
a force-sensor bias (they are indistinguishable from force/position data). The friction law
is the exponential Stribeck model of ``002_af30b681d6ccfd6c.txt`` eq (1) with the sign
regularised by ``tanh`` as in ``003_54985feb8193da53.txt`` eq (12)
(:func:`hydro_envs.laws.friction.stribeck_exponential`). ``F_stop`` is the Hunt-Crossley end
stop of :mod:`hydro_envs.laws.contact` at 0 and ``stroke``.

Defaults are "assumed: generic stage": a 1 kg carriage on a lubricated guide (F_C 10 N,
F_S 15 N, v_S 5 mm/s, b 20 N s/m) -- of the order of 004 Table 2 (F_S = 35.48 N,
F_C = 15.31 N, v_S = 3.27 mm/s for a rodless cylinder), scaled down to a small stage.

Regularisation and cost (CONTRIBUTING, "Numerics and cost"): the sign velocity ``v_eps``
sets the stiffest mode, ``(F_S / v_eps + b + (F_S - F_C) / v_S) / m`` at v = 0. The default
``v_eps = 0.5 mm/s = v_S / 10`` (the ratio Simscape uses between its Coulomb and Stribeck
velocities, docs/references.md) gives 3.1e4 1/s, i.e. 14 RK4 sub-steps per 1 ms for the nominal
stage; a tenfold smaller ``v_eps`` costs ten times more sub-steps and changes the friction
force only for |v| < a few v_eps, where a real stage sticks anyway. Identification models
that use an exact ``sign(v)`` must discard samples with |v| below a few ``v_eps``
(:mod:`identification.slider` does, ``min_speed``).

Guard: the state has no physical bound to project onto (no pressures, the stops are a
continuous force), so :func:`slider_guard` only counts; it returns 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba as nb
import numpy as np

from hydro_envs.contract import PlantModel
from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.contact import CONTACT_DAMPING_RAMP, backlash_force, end_stop_force
from hydro_envs.laws.friction import stribeck_exponential
from hydro_envs.plants.slider.params import (  # noqa: F401  (re-exported)
    I_AC, I_ASTOP, I_B, I_F0, I_FC, I_FMAX, I_FS, I_GAP, I_KC, I_KSTOP, I_L, I_M, I_MU, I_VEPS, I_VS, N_PARAMS,
    PLANT, SliderParams,
)
from hydro_envs.plants.slider.spec import SPEC
from hydro_envs.sim.simulate import simulate
from hydro_envs.sim.stiffness import substeps_from_stiffness

__all__ = [
    "CONTRACT",
    "SliderParams",
    "PLANT",
    "STATE_NAMES",
    "STATE_UNITS",
    "N_STATES",
    "X",
    "V",
    "XD",
    "VD",
    "slider_rhs",
    "slider_guard",
    "slider_friction",
    "stiffness_modes",
    "backlash_contact_rate",
    "drive_acceleration",
    "simulate_slider",
    "rest_state",
    "ACCURATE_SAFETY",
]

STATE_NAMES = ("x", "v", "xd", "vd")
STATE_UNITS = ("m", "m/s", "m", "m/s")
N_STATES = 4
X, V, XD, VD = range(N_STATES)

#: sensor outputs (noise-free): measured channel -> the state index it reads, and measured
#: channel -> the state index whose time derivative it reads
STATE_OUTPUTS: dict[str, int] = {"x": X}
DERIVATIVE_OUTPUTS: dict[str, int] = {}

#: Sub-step safety of :func:`simulate_slider`. The kernel's stability default (0.8 of RK4's
#: real-axis limit, 14 sub-steps per 1 ms for the nominal stage) keeps the stiff tanh mode
#: stable but resolves it coarsely: over 1 s of random +-30 N steps with 40 stick-slip
#: transitions it is 6 um / 0.14 mm/s off the Radau reference; 0.2 (56 sub-steps) gives
#: 5 nm / 0.2 um/s (asymptotic RK4 range). This is an identification plant: records must be
#: accurate to well below sensor noise, and a 2-state sub-step costs only ~30 ns.
ACCURATE_SAFETY = 0.2


@njit_noalloc
def slider_rhs(y, u, p, dy):
    """Time derivative ``dy`` of ``y = (x, v, x_d, v_d)`` under applied force ``u[0]`` [N]."""
    x = y[X]
    v = y[V]
    gap = p[I_GAP]
    f_stop = end_stop_force(x, v, 0.0, p[I_L], p[I_KSTOP], p[I_ASTOP])
    if gap <= 0.0:  # rigid drive: one body, the driven states follow the measured ones
        f_friction = stribeck_exponential(
            v, p[I_FC], p[I_FS], p[I_VS], p[I_B], p[I_VEPS]
        )  # 002 eq (1), tanh sign 003 eq (12)
        dy[X] = v
        dy[V] = (u[0] - p[I_F0] - f_friction + f_stop) / p[I_M]
        dy[XD] = dy[X]
        dy[VD] = dy[V]
        return
    mu = p[I_MU]
    vd = y[VD]
    f_load = mu * stribeck_exponential(v, p[I_FC], p[I_FS], p[I_VS], p[I_B], p[I_VEPS])
    f_c = backlash_force(y[XD] - x, vd - v, gap, p[I_KC], p[I_AC])
    dy[X] = v
    dy[V] = (f_c - mu * p[I_F0] - f_load + f_stop) / (mu * p[I_M])
    dy[XD] = vd
    dy[VD] = drive_acceleration(p, vd, u[0], f_c)


@nb.njit(cache=True, error_model="numpy", inline="always")
def drive_acceleration(p, vd, f, f_c):
    """Acceleration [m/s^2] of the driven body behind a play: ``(1 - mu) m v_d' = f - (1 - mu)
    (F_0 + F_f(v_d)) - F_c`` under the applied force ``f`` [N] and the contact force ``f_c`` [N]
    it passes to the load."""
    md = 1.0 - p[I_MU]
    f_drive = md * stribeck_exponential(vd, p[I_FC], p[I_FS], p[I_VS], p[I_B], p[I_VEPS])
    return (f - md * p[I_F0] - f_drive - f_c) / (md * p[I_M])


@njit_noalloc
def slider_guard(y, p):
    """Nothing to project (the stops are a continuous force); returns 0 clamps."""
    return 0


def slider_friction(v: np.ndarray | float, params: SliderParams) -> np.ndarray:
    """Friction force [N] of ``params`` at velocity ``v`` (vectorised, same law as the RHS)."""
    v = np.asarray(v, dtype=np.float64)
    mag = params.coulomb_friction + (params.static_friction - params.coulomb_friction) * np.exp(
        -np.abs(v) / params.stribeck_velocity
    )
    return mag * np.tanh(v / params.friction_sign_velocity) + params.viscous_friction * v


def stiffness_modes(params: SliderParams) -> dict[str, float]:
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s].

    * ``friction``: |dF_f/dv| / m at v = 0, bounded by
      ``(F_S / v_eps + b + (F_S - F_C) / v_S) / m`` (tanh slope times the largest magnitude
      F_S, viscous slope, and the Stribeck decay slope, which is negative damping).
    * ``end_stop``: contact spring ``sqrt(k / m)`` plus its damping ``alpha F_max / m`` at
      the penetration where the stop holds ``force_max`` (as the servo cylinder); with a play
      on the load's mass ``mu m``.
    * ``backlash`` (with a play): the drive-load contact on the reduced mass
      ``mu (1 - mu) m`` (:func:`backlash_contact_rate`).
    """
    m = params.mass
    # with a play the end stop acts on the load alone, the contact across the play on the
    # reduced mass; each body's friction scales with its mass, so its rate per unit mass is unchanged
    m_stop = params.load_mass_fraction * m if params.backlash_gap > 0.0 else m
    modes = {
        "friction": (
            params.static_friction / params.friction_sign_velocity
            + params.viscous_friction
            + (params.static_friction - params.coulomb_friction) / params.stribeck_velocity
        )
        / m,
        "end_stop": math.sqrt(params.stop_stiffness / m_stop)
        + params.stop_damping * (params.force_max + params.static_friction) / m_stop,
    }
    if params.backlash_gap > 0.0:
        mu = params.load_mass_fraction
        modes["backlash"] = backlash_contact_rate(params, mu * (1.0 - mu) * m)
    return modes


def backlash_contact_rate(params: SliderParams, mass: float) -> float:
    """Largest eigenvalue magnitude [1/s] of the play's contact acting on ``mass`` [kg].

    The contact spring ``k`` plus the slope of the damper while it engages over
    :data:`~hydro_envs.laws.contact.CONTACT_DAMPING_RAMP`, ``c v / ramp``, at the fastest closing
    speed: the drive accelerated by the full force over twice the play,
    ``v = sqrt(4 g F_max / ((1 - mu) m))``; then the damper ``c / mass``.
    """
    md = (1.0 - params.load_mass_fraction) * params.mass
    v_close = math.sqrt(4.0 * params.backlash_gap * (params.force_max + params.static_friction) / md)
    k_eff = params.coupling_stiffness + params.coupling_damping * v_close / CONTACT_DAMPING_RAMP
    return math.sqrt(k_eff / mass) + params.coupling_damping / mass


def rest_state(params: SliderParams, x: float | None = None) -> np.ndarray:
    """State at rest at ``x`` (default mid-stroke)."""
    y = np.zeros(N_STATES)
    y[X] = y[XD] = 0.5 * params.stroke if x is None else x
    return y


def simulate_slider(
    params: SliderParams | Sequence[SliderParams],
    force: np.ndarray,
    dt: float,
    y0: np.ndarray | None = None,
    *,
    n_sub: int | None = None,
    safety: float = ACCURATE_SAFETY,
) -> np.ndarray:
    """Roll the slider out under a zero-order-held force on the batched RK4 kernel.

    ``force`` [N] has shape ``(n,)`` (one record) or ``(batch, n)``; ``params`` is one
    parameter set or one per record; ``y0`` is ``(4,)`` or ``(batch, 4)``, or ``(x, v)`` with
    the driven body at the measured one (default: rest at mid-stroke). Sub-steps follow from
    :func:`stiffness_modes` with ``safety`` (default :data:`ACCURATE_SAFETY`, see there) unless
    ``n_sub`` is given.
    Returns states ``(n + 1, 4)`` or ``(batch, n + 1, 4)``: row ``k`` is the state at
    ``t = k dt``, and ``force[k]`` acts on ``[k dt, (k + 1) dt)``.
    """
    force = np.asarray(force, dtype=np.float64)
    single = force.ndim == 1
    F = np.atleast_2d(force)
    if F.ndim != 2:
        raise ValueError(f"force must have shape (n,) or (batch, n), got {force.shape}")
    if not np.all(np.isfinite(F)):
        raise ValueError("force contains NaN or inf; every sample must be finite [N]")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt = {dt!r} must be a finite time step > 0 s")
    batch, n = F.shape
    plist = [params] * batch if isinstance(params, SliderParams) else list(params)
    if len(plist) != batch:
        raise ValueError(f"got {len(plist)} parameter sets for {batch} force records")
    if y0 is None:
        Y = np.stack([rest_state(q) for q in plist])
    else:
        y0 = np.asarray(y0, dtype=np.float64)
        if y0.shape[-1] == 2:  # (x, v): the driven body at the measured one
            y0 = np.concatenate([y0, y0], axis=-1)
        Y = np.array(np.broadcast_to(y0, (batch, N_STATES)))
    if not np.all(np.isfinite(Y)):
        raise ValueError("y0 contains NaN or inf")
    nsub: int | list[int]
    if n_sub is None:
        nsub = [substeps_from_stiffness(stiffness_modes(q), dt, safety)[0] for q in plist]
    else:
        if int(n_sub) < 1:
            raise ValueError(f"n_sub = {n_sub} must be >= 1")
        nsub = int(n_sub)
    out = simulate(SPEC, plist, F[:, :, None], Y, dt, n_sub=nsub)
    return out[0] if single else out


#: the plant's typed contract (hydro_envs.contract.PlantModel): what the registry, sim, envs,
#: identification, diagnosis and the soak test read of this model
CONTRACT = PlantModel(
    state_names=STATE_NAMES, state_units=STATE_UNITS, stiffness_modes=stiffness_modes,
    state_outputs=STATE_OUTPUTS, derivative_outputs=DERIVATIVE_OUTPUTS,
    rest_state=rest_state,
)
