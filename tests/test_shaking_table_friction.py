"""Shaking table (seed 003): the seals' LuGre friction against independent truths.

* the steady state equals 003 eq (11) with the sign, written out by hand from Table 2;
* beta of eq (12) read per mm/s is a near-sign law, read per s/m it is not (the params' decision);
* a table at rest under a net force below the breakaway level holds on its bristles (drift within
  the bristle deflection), above it slides;
* the friction never delivers power (its power less the bristles' stored-energy rate >= 0).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hydro_envs import registry
from hydro_envs.plants.shaking_table import energy as st_energy
from hydro_envs.plants.shaking_table import model as st
from hydro_envs.plants.shaking_table.params import ShakingTableParams
from hydro_envs.sim.stiffness import substeps_from_stiffness

NOMINAL = ShakingTableParams()
DT = 1e-3


def eq11(v: float, p: ShakingTableParams) -> float:
    """003 eq (11) with sign(v), Table 2 values of ``p`` (written out, not the plant's code)."""
    return ((p.coulomb_friction + (p.static_friction - p.coulomb_friction) * math.exp(-(v / p.stribeck_velocity) ** 2))
            * math.copysign(1.0, v) + p.viscous_friction * v)


@pytest.mark.parametrize("preset", ["modified_ifas", "ifas"])
@pytest.mark.parametrize("v", [1e-3, -3e-3, 0.01, -0.014, 0.03, 0.08, -0.2])
def test_steady_state_is_eq_11_with_the_sign(preset, v):
    """The bristle state integrated (Radau, independent of the plant's RK4) at a constant velocity
    settles where the force is eq (11) exactly -- also above the relaxation cap's speed."""
    p = ShakingTableParams.preset(preset)
    pa = p.to_array()

    def rate(_t, z):
        return [st.seal_force(v, z[0], pa)[1]]

    t_end = 50.0 * p.static_friction / (p.bristle_stiffness * abs(v)) + 0.05  # many relaxation lengths
    sol = solve_ivp(rate, (0.0, t_end), [0.0], method="Radau", rtol=1e-10, atol=1e-15)
    f, dz = st.seal_force(v, sol.y[0, -1], pa)
    assert f == pytest.approx(eq11(v, p), rel=1e-6)
    assert abs(dz) < 1e-9


def test_beta_per_mm_per_s_is_the_sign_and_per_m_per_s_is_not():
    """The params' reading of Table 2's beta: 7.33 s/mm makes eq (12) eq (11) within 0.1 % from
    1 mm/s on; 7.33 s/m would give 76 N at 10 mm/s where eq (11) gives 987 N."""
    p = NOMINAL
    assert p.tanh_gain == 7330.0
    for v in (1e-3, 0.01, 0.014, 0.1):
        tanh_law = eq11(v, p) - p.viscous_friction * v
        assert math.tanh(p.tanh_gain * v) * tanh_law == pytest.approx(tanh_law, rel=1e-3)
    g10 = eq11(0.01, p) - p.viscous_friction * 0.01
    assert math.tanh(7.33 * 0.01) * g10 + p.viscous_friction * 0.01 == pytest.approx(76.4, abs=1.0)
    assert eq11(0.01, p) == pytest.approx(987.0, abs=1.0)


def _held_table(force: float, seconds: float) -> tuple[np.ndarray, ShakingTableParams]:
    """Table at rest, valve sealed, no leakage, constant modulus and a 0.5 m^3 dead volume per side
    (an oil spring of 1.7 kN/m: the pressure difference, i.e. the net force, stays ``force``);
    returns the states at each ms and the parameters."""
    p = dataclasses.replace(NOMINAL, flow_coefficient=0.0, internal_leakage=0.0, external_leakage=0.0,
                            bulk_modulus_model=0.0, dead_volume=0.5)
    y = st.rest_state(p)
    dp = force / p.piston_area
    y[st.PA] += 0.5 * dp
    y[st.PB] -= 0.5 * dp
    Y = y[None, :].copy()
    P = p.to_array()[None, :]
    nsub = np.array([substeps_from_stiffness(st.stiffness_modes(p), DT)[0]], dtype=np.int64)
    W, c = np.zeros((1, 5, st.N_STATES)), np.zeros(1, dtype=np.int64)
    out = [Y[0].copy()]
    step = registry.get("shaking_table").kernels.step_serial
    for _ in range(int(seconds / DT)):
        step(Y, np.zeros((1, 1)), P, DT, nsub, W, c)
        out.append(Y[0].copy())
    return np.array(out), p


@pytest.mark.parametrize("share", [0.3, 0.8, 0.95])
def test_table_at_rest_under_a_force_below_breakaway_holds(share):
    """Below F_s the bristles take the net force and the table stops: it creeps while its
    bristles load, by at least the closed form of the rate law under monotone loading at the
    level at rest, ``dz/dx = 1 - sigma0 z / F_s``: ``x = -(F_s / sigma0) ln(1 - F / F_s)``, and
    by at most twice the same closed form at the lowest level eq (11) reaches at the creep's peak
    speed (the force is applied as a step: the table swings back by a few per cent of its peak
    speed, and LuGre ratchets a little on each swing); then it holds -- no drift, the bristles
    carry the force. Without the seals' stick the same force would move it by 0.6 m against the
    weak oil spring."""
    p0 = NOMINAL
    force = share * p0.static_friction
    ys, p = _held_table(force, 2.0)
    x, v = ys[:, st.X], ys[:, st.V]
    assert v.min() > -0.05 * v.max()  # nearly monotone loading
    g_lo = p.coulomb_friction + (p.static_friction - p.coulomb_friction) * math.exp(
        -(v.max() / p.stribeck_velocity) ** 2)
    lo = -(p.static_friction / p.bristle_stiffness) * math.log(1.0 - force / p.static_friction)
    hi = -(g_lo / p.bristle_stiffness) * math.log(1.0 - force / g_lo)
    assert lo * (1 - 1e-3) <= x[-1] <= 2.0 * hi, (lo, x[-1], hi)  # 0.95 F_s: 94 <= 183 <= 230 um
    assert abs(x[-1] - x[-500]) < 1e-9  # and no creep over the last 0.5 s
    assert abs(v[-1]) < 1e-8
    assert p.bristle_stiffness * ys[-1, st.Z] == pytest.approx(force, rel=1e-3)


def test_table_above_breakaway_slides():
    force = 1.1 * NOMINAL.static_friction
    ys, _ = _held_table(force, 0.5)
    assert ys[-1, st.X] > 5e-3  # breaks away and slides (the bristle deflection is 34 um)
    assert ys[-1, st.V] > 0.0


def test_friction_never_delivers_power():
    """mech_terms' friction dissipation ``F v - sigma0 z z'`` >= 0 over speeds and deflections
    inside the bristle bound (module docstring of hydro_envs.laws.seal_friction), nominal and
    IFAS column, the table without specimen (the lightest mass)."""
    rng = np.random.default_rng(0)
    for p in (NOMINAL, ShakingTableParams.preset("ifas", "none")):
        pa = p.to_array()
        z_max = p.static_friction / p.bristle_stiffness
        for _ in range(4000):
            v = rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-6, 0)
            z = rng.uniform(-z_max, z_max)
            y = st.rest_state(p)
            y[st.V] = v
            y[st.Z] = z
            f, dz = st.seal_force(v, z, pa)
            assert f * v - p.bristle_stiffness * z * dz >= -1e-9 * (abs(f * v) + 1.0)
            _, _, d, _, _ = st_energy.mech_terms(y, pa)
            assert d >= -1e-9 * (abs(f * v) + 1.0)


def test_without_dry_friction_leaves_viscous_friction():
    spec = registry.get("shaking_table")
    values = spec.without_dry_friction({})
    assert values == {"coulomb_friction": 0.0, "static_friction": 0.0}
    p = ShakingTableParams.from_mapping(values)
    f, dz = st.seal_force(0.02, 1e-5, p.to_array())
    assert (f, dz) == (pytest.approx(p.viscous_friction * 0.02), 0.0)


def test_low_frequency_task_reference_and_registration():
    """ShakingTableLowFrequency-v0: 8 s episodes of a velocity sine from rest (0.25-0.5 Hz, 5-25
    mm/s peak, 4-8 reversals), the reference accelerations those of that motion."""
    import gymnasium as gym

    import hydro_envs  # noqa: F401
    from hydro_envs.envs.shaking_table.references import low_frequency_reference

    assert gym.spec("hydro_envs/ShakingTableLowFrequency-v0").max_episode_steps == 8000
    rng = np.random.default_rng(0)
    for _ in range(20):
        a, d = low_frequency_reference(rng, 8051, DT)
        v = np.cumsum(a) * DT  # from rest
        assert d[0] == 0.0 and abs(v[0]) < 1e-3
        assert 5e-3 * 0.99 < np.max(np.abs(v)) < 25e-3 * 1.01
        reversals = np.count_nonzero(np.diff(np.sign(v[10:8000])) != 0)
        assert 3 <= reversals <= 8
    env = gym.make("hydro_envs/ShakingTableLowFrequency-v0", randomize=False)
    _, info = env.reset(seed=0)
    ref = env.unwrapped._batch.REF[0]
    assert np.max(np.abs(ref)) < 0.1
    env.close()
