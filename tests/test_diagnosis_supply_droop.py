"""Supply-pressure droop on records from a generator independent of the workflow's simulator.

The generator writes the valve-controlled cylinder of 002 eq (8) out again (its own
regularised orifice root, its own spool and friction code, scipy's Radau) and feeds the valve
from a pressure-compensated pump through a 1 L hose instead of a constant supply: the hose
pressure is a state, ``p_s' = beta / V_s (Q_pump - Q_P - Q_relief)``, the pump delivers
``Q_pump = Q_max clip((p_set - p_s) / dp_c, 0, 1)``, and a relief valve opening 0.2 MPa above
``p_set`` takes the flow the valve pushes back into the hose while it brakes the piston. In steady flow that is a supply whose
pressure falls linearly with the drawn flow, ``R = dp_c / Q_max``, with a lag (the hose) the
catalogue's static droop does not have. A P position loop with velocity feed-forward runs
inside the solve; the recorded command of sample k is its mean over ``[t_k, t_k+1)`` (an
integral state), so a zero-order-held replay gives the spool the same impulse.

Expected: with a stiff supply the record is effect-free for the diagnosis (``none``); with the
drooping pump the workflow names ``supply_droop`` first, with ``R`` near ``dp_c / Q_max``. The
hose's lag (``tau = V_s R / beta`` = 29 ms) is not in the catalogue's static droop: the position
residual left is 51 noise floors (10 mL hose, tau 0.3 ms: 12), so the verdict may be
``unexplained`` -- with supply_droop named, never another effect.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from identification.diagnosis import Record, diagnose, diagnosis_plant
from identification.diagnosis.synthetic import base_for

DT = 1e-3
Q_MAX = 5e-4  # m^3/s, pump flow at full stroke (30 L/min)
DP_C = 10e6  # Pa, compensator band: the supply falls by this much at Q_MAX
V_HOSE = 1e-3  # m^3
K_RELIEF = 1e-9  # m^3/(s Pa): the relief valve passes 1 L/s at 1 MPa over its setting
R_TRUE = DP_C / Q_MAX  # 2e10 Pa s/m^3


def _root(dp, tr=2e4):
    """Signed root with a laminar core (its own transition, not the plant's 1e5 Pa)."""
    return dp / (dp * dp + tr * tr) ** 0.25


def servo_record(p, droop: bool, seed: int, duration: float) -> Record:
    """Closed-loop record of 002 eq (8) (values of ``p``, equations written here) fed by a
    stiff supply (``droop=False``) or by the compensated pump and hose of the module docstring."""
    rng = np.random.default_rng(seed)
    f = np.array([0.35, 0.8, 1.9, 3.3])
    amp = np.array([0.018, 0.006, 0.002, 0.001])
    ph = rng.uniform(0, 2 * np.pi, f.size)
    w_ref = 2 * np.pi * f
    centre = 0.5 * p.stroke
    k_edge = p.discharge_coefficient * p.area_gradient * math.sqrt(2 / p.oil_density)
    kq = k_edge * p.spool_stroke * math.sqrt((p.supply_pressure - p.tank_pressure) / 2) / p.piston_area / p.command_max
    a, m, L = p.piston_area, p.mass, p.stroke
    wv, zv = p.valve_natural_frequency, p.valve_damping
    p_set = p.supply_pressure

    def rhs(t, y):
        x, v, p1, p2, xv, vv, ps, _ = y
        r = centre + np.sum(amp * np.sin(w_ref * t + ph))
        dr = np.sum(amp * w_ref * np.cos(w_ref * t + ph))
        u = float(np.clip((40.0 * (r - x) + dr) / kq, -p.command_max, p.command_max))
        xo = min(max(xv, -p.spool_stroke), p.spool_stroke)
        sup = ps if droop else p_set
        if xo >= 0:
            q1 = k_edge * xo * _root(sup - p1)
            q2 = -k_edge * xo * _root(p2 - p.tank_pressure)
            q_p = q1
        else:
            q1 = k_edge * xo * _root(p1 - p.tank_pressure)
            q2 = -k_edge * xo * _root(sup - p2)
            q_p = q2
        v1 = a * x + p.line_volume_1
        v2 = a * (L - x) + p.line_volume_2
        fric = p.coulomb_friction * math.tanh(v / p.friction_sign_velocity) + p.viscous_friction * v
        q_pump = Q_MAX * min(max((p_set - ps) / DP_C, 0.0), 1.0)
        q_relief = K_RELIEF * max(ps - p_set - 2e5, 0.0)
        return [v, (a * (p1 - p2) - fric) / m,
                p.bulk_modulus / v1 * (q1 - a * v), p.bulk_modulus / v2 * (q2 + a * v),
                vv, -wv * wv * xv - 2 * zv * wv * vv + p.spool_gain * wv * wv * u,
                p.bulk_modulus / V_HOSE * (q_pump - q_p - q_relief) if droop else 0.0, u]

    pm = 0.5 * (p.supply_pressure + p.tank_pressure)
    x0 = centre + float(np.sum(amp * np.sin(ph)))
    y0 = [x0, 0.0, pm, pm, 0.0, 0.0, p_set, 0.0]
    n = int(round(duration / DT)) + 1
    tt = DT * np.arange(n + 1)
    with np.errstate(over="ignore"):  # Radau's finite-difference Jacobian probes far from the solution
        sol = solve_ivp(rhs, (0.0, tt[-1]), y0, method="Radau", t_eval=tt, rtol=1e-7,
                        atol=[1e-9, 1e-7, 1, 1, 1e-10, 1e-7, 1, 1e-9])
    assert sol.success, sol.message
    u = np.diff(sol.y[-1]) / DT
    chans = {"x": sol.y[0, :n] + 1e-6 * rng.standard_normal(n),
             "p1": sol.y[2, :n] + 5e3 * rng.standard_normal(n),
             "p2": sol.y[3, :n] + 5e3 * rng.standard_normal(n)}
    return Record(DT, u, chans, f"independent servo, {'drooping' if droop else 'stiff'} supply, seed {seed}")


@pytest.fixture(scope="module")
def base():
    return base_for(diagnosis_plant("servo_cylinder"), None)


def _diagnose(base, droop):
    fit = servo_record(base, droop, 1, 5.0)
    hold = servo_record(base, droop, 1001, 3.0)
    return diagnose("servo_cylinder", [fit], [hold], base=base, max_effects=1, maps=False), fit


def test_stiff_supply_record_is_effect_free(base):
    res, _ = _diagnose(base, False)
    assert res.verdict == "none", (res.verdict, res.reason, [(c.name, c.gain, c.reasons) for c in res.rounds[0].candidates])


def test_drooping_pump_is_named_supply_droop(base):
    res, fit = _diagnose(base, True)
    # the record draws enough flow for the droop to matter: > 1 MPa at its fastest
    v = np.gradient(fit.channels["x"], DT)
    assert R_TRUE * base.piston_area * np.percentile(np.abs(v), 99) > 1e6
    assert [e["name"] for e in res.effects] == ["supply_droop"], (res.verdict, res.reason, res.effects)
    r = res.effects[0]["parameters"]["supply_line_resistance"]
    assert r == pytest.approx(R_TRUE, rel=0.3)
    assert res.verdict in ("named", "unexplained"), res.reason
    if res.verdict == "unexplained":
        assert "named so far: supply_droop" in res.reason
