"""Compiled fixed-step integration of every plant, for one copy or a whole batch.

Why one dispatching kernel: numba cannot cache a kernel that receives the right-hand side
as a first-class function or closure (it recompiles in every process), so the integrator
calls each plant's right-hand side through a constant plant id instead. Adding a plant means
adding one branch to :func:`plant_rhs` and :func:`plant_guard`.

Layout of a batch: ``Y`` states ``(n, n_states)``, ``U`` inputs ``(n, n_inputs)`` held
constant over the env step (zero-order hold, as a DAC does), ``P`` parameters
``(n, n_params)``, ``NSUB`` sub-steps per env step ``(n,)``, ``W`` workspace
``(n, 5, n_states)``, ``clamps`` guard counters ``(n,)``. One call advances copy ``i`` by one
env step ``dt`` in ``NSUB[i]`` classical RK4 sub-steps -- each copy's sub-step comes from its
own parameters' stiffness bound, so a stiff draw never slows the others down; after each
sub-step the plant's guard projects the state onto the physical set (pressure floor) and
counts how often it had to.

``step_batch_serial`` serves the single env (a parallel region costs several microseconds to
enter, more than a whole env step); ``step_batch_parallel`` serves the vector envs.
"""

from __future__ import annotations

import numba as nb

from hydro_envs.plants.ls_circuit import ls_circuit_guard, ls_circuit_rhs
from hydro_envs.plants.ls_compensator import ls_compensator_guard, ls_compensator_rhs
from hydro_envs.plants.rodless_cylinder import rodless_cylinder_guard, rodless_cylinder_rhs
from hydro_envs.plants.force_actuator import force_actuator_guard, force_actuator_rhs
from hydro_envs.plants.servo_cylinder import servo_cylinder_guard, servo_cylinder_rhs
from hydro_envs.plants.shaking_table import shaking_table_guard, shaking_table_rhs
from hydro_envs.plants.slider import slider_guard, slider_rhs

__all__ = [
    "SERVO_CYLINDER",
    "FORCE_ACTUATOR",
    "LS_COMPENSATOR",
    "LS_CIRCUIT",
    "SHAKING_TABLE",
    "SLIDER",
    "RODLESS_CYLINDER",
    "plant_rhs",
    "plant_guard",
    "rk4_substeps",
    "step_batch_serial",
    "step_batch_parallel",
]

# Plant ids (compile-time constants of the dispatch).
SERVO_CYLINDER = 0
FORCE_ACTUATOR = 2
LS_COMPENSATOR = 3  # LS pump flow compensator + pilot pipe (hydro_envs.plants.ls_compensator)
LS_CIRCUIT = 5  # load-sensing pump circuit with that compensator (hydro_envs.plants.ls_circuit)
SHAKING_TABLE = 1
SLIDER = 6  # generic force-driven slider (hydro_envs.plants.slider)
RODLESS_CYLINDER = 4  # pneumatic rodless cylinder, seed 004 (hydro_envs.plants.rodless_cylinder)


@nb.njit(cache=True, error_model="numpy", inline="always")
def plant_rhs(plant_id, y, u, p, dy):
    """Evaluate the right-hand side of plant ``plant_id`` into ``dy``."""
    if plant_id == SERVO_CYLINDER:
        servo_cylinder_rhs(y, u, p, dy)
    elif plant_id == FORCE_ACTUATOR:
        force_actuator_rhs(y, u, p, dy)
    elif plant_id == LS_COMPENSATOR:
        ls_compensator_rhs(y, u, p, dy)
    elif plant_id == LS_CIRCUIT:
        ls_circuit_rhs(y, u, p, dy)
    elif plant_id == SHAKING_TABLE:
        shaking_table_rhs(y, u, p, dy)
    elif plant_id == SLIDER:
        slider_rhs(y, u, p, dy)
    elif plant_id == RODLESS_CYLINDER:
        rodless_cylinder_rhs(y, u, p, dy)
    else:
        raise ValueError("unknown plant id")


@nb.njit(cache=True, error_model="numpy", inline="always")
def plant_guard(plant_id, y, p):
    """Project ``y`` onto the plant's physical set; return the number of clamped states."""
    if plant_id == SERVO_CYLINDER:
        return servo_cylinder_guard(y, p)
    if plant_id == FORCE_ACTUATOR:
        return force_actuator_guard(y, p)
    if plant_id == LS_COMPENSATOR:
        return ls_compensator_guard(y, p)
    if plant_id == LS_CIRCUIT:
        return ls_circuit_guard(y, p)
    if plant_id == SHAKING_TABLE:
        return shaking_table_guard(y, p)
    if plant_id == SLIDER:
        return slider_guard(y, p)
    if plant_id == RODLESS_CYLINDER:
        return rodless_cylinder_guard(y, p)
    return 0


@nb.njit(cache=True, error_model="numpy")
def rk4_substeps(plant_id, y, u, p, h, n_sub, work):
    """Advance ``y`` in place by ``n_sub`` RK4 steps of ``h`` seconds; return guard clamps.

    ``work`` is a ``(5, n_states)`` scratch array (k1..k4 and the stage state).
    """
    ny = y.shape[0]
    k1 = work[0]
    k2 = work[1]
    k3 = work[2]
    k4 = work[3]
    stage = work[4]
    half = 0.5 * h
    sixth = h / 6.0
    clamps = 0
    for _ in range(n_sub):
        plant_rhs(plant_id, y, u, p, k1)
        for j in range(ny):
            stage[j] = y[j] + half * k1[j]
        plant_rhs(plant_id, stage, u, p, k2)
        for j in range(ny):
            stage[j] = y[j] + half * k2[j]
        plant_rhs(plant_id, stage, u, p, k3)
        for j in range(ny):
            stage[j] = y[j] + h * k3[j]
        plant_rhs(plant_id, stage, u, p, k4)
        for j in range(ny):
            y[j] += sixth * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        clamps += plant_guard(plant_id, y, p)
    return clamps


@nb.njit(cache=True, error_model="numpy")
def step_batch_serial(plant_id, Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one env step of ``dt`` seconds in ``NSUB[i]`` sub-steps (serial)."""
    for i in range(Y.shape[0]):
        clamps[i] += rk4_substeps(plant_id, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])


@nb.njit(cache=True, parallel=True, error_model="numpy")
def step_batch_parallel(plant_id, Y, U, P, dt, NSUB, W, clamps):
    """Advance every copy by one env step of ``dt`` seconds in ``NSUB[i]`` sub-steps (threads)."""
    for i in nb.prange(Y.shape[0]):
        clamps[i] += rk4_substeps(plant_id, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])
