"""Pneumatic supply droop on rodless-cylinder records from a generator independent of the workflow.

The generator writes seed 004's valve-controlled rodless cylinder out again: port area eq (2),
the nozzle law of eqs (3)-(4) with its own linear tail near equal pressures (above a pressure
ratio of 0.995, not the plant's 0.999), adiabatic chambers as mass and energy balances
(eqs (8)-(13)), the static friction curve and a second-order spool, integrated by scipy's
Radau. Its supply is either stiff (0.7 MPa absolute at the P port) or a relieving pressure
regulator feeding the valve through a 5 mL hose: the hose pressure is a state,
``p_h' = R_gas T_s / V_h (mdot_reg - mdot_P)`` with ``mdot_reg = (p_set - p_h) / R`` (the
regulator's linear flow characteristic). In steady flow the port then sits at
``p_set - R mdot_P``, the catalogue's static droop, with a lag ``V_h R / (R_gas T_s)`` = 24 ms
that the catalogue does not have. A P position loop with velocity feed-forward runs inside the
solve; the recorded command of sample k is its mean over ``[t_k, t_k+1)``.

Expected: with the stiff supply the record is effect-free for the diagnosis (``none``); with the
drooping regulator the workflow names ``supply_droop`` first, with ``R`` near the truth, and
nothing else. The hose's lag is not in the static droop: the position residual left stays far
above the noise floor (266 floors), so the verdict is ``unexplained`` with supply_droop named.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from identification.diagnosis import Record, diagnose, diagnosis_plant
from identification.diagnosis.synthetic import base_for

DT = 1e-3
R_TRUE = 4e8  # Pa s/kg: 0.1 MPa lower at the port at 0.25 g/s (about 12 L/min ANR)
V_HOSE = 5e-6  # m^3 (0.4 m of 4 mm hose)
RATIO_LIN = 0.995  # this generator's laminar tail


def _port_area(x, r):
    """Eq (2): area uncovered when an edge has travelled ``x`` past the near rim of a round port."""
    if x <= 0.0:
        return 0.0
    if x >= 2.0 * r:
        return math.pi * r * r
    h = r - x
    return r * r * math.acos(h / r) - h * math.sqrt(r * r - h * h)


def _nozzle(cd_s, p_up, p_down, t_up, kappa, r_gas):
    """Eqs (3)-(4): mass flow from the higher to the lower pressure (signed), linear above RATIO_LIN."""
    sign = 1.0
    if p_up < p_down:
        p_up, p_down, sign = p_down, p_up, -1.0
    if cd_s <= 0.0 or p_up <= 0.0:
        return 0.0
    crit = (2.0 / (kappa + 1.0)) ** (kappa / (kappa - 1.0))

    def psi(r):
        if r <= crit:
            return math.sqrt(kappa * (2.0 / (kappa + 1.0)) ** ((kappa + 1.0) / (kappa - 1.0)))
        return math.sqrt(2.0 * kappa / (kappa - 1.0) * (r ** (2.0 / kappa) - r ** ((kappa + 1.0) / kappa)))

    r = p_down / p_up
    f = psi(r) if r <= RATIO_LIN else psi(RATIO_LIN) * (1.0 - r) / (1.0 - RATIO_LIN)
    return sign * cd_s * p_up * f / math.sqrt(r_gas * max(t_up, 1.0))  # (Radau's Jacobian probes)


def rodless_record(p, droop: bool, seed: int, duration: float) -> Record:
    """Closed-loop record of the 004 rodless cylinder (values of ``p``, equations written here),
    fed by a stiff supply or by the regulator and hose of the module docstring."""
    rng = np.random.default_rng(seed)
    f = np.array([0.3, 0.7, 1.6, 3.1])
    amp = np.array([0.025, 0.008, 0.003, 0.001])
    ph = rng.uniform(0, 2 * np.pi, f.size)
    w_ref = 2 * np.pi * f
    centre = 0.5 * p.stroke
    area = 0.25 * math.pi * p.bore ** 2
    k, rg, ts = p.heat_capacity_ratio, p.gas_constant, p.supply_temperature
    cd, rp, lap = p.discharge_coefficient, p.port_radius, p.valve_underlap
    pe, p_set = p.exhaust_pressure, p.supply_pressure
    kv = p.spool_stroke / (p.command_max - p.command_centre)
    wv, zv = p.valve_natural_frequency, p.valve_damping

    def rhs(t, s):
        y, v, pa, pb, ma, mb, xv, vv, p_h, _ = s
        r = centre + np.sum(amp * np.sin(w_ref * t + ph))
        dr = np.sum(amp * w_ref * np.cos(w_ref * t + ph))
        u = float(np.clip(p.command_centre + 150.0 * (r - y) + dr / 0.3, 0.0, p.command_max))
        va = area * y + p.dead_volume_a
        vb = area * (p.stroke - y) + p.dead_volume_b
        ta = pa * va / (ma * rg)
        tb = pb * vb / (mb * rg)
        xo = min(max(xv, -p.spool_stroke), p.spool_stroke)
        s_p = cd * _port_area(lap + xo, rp)  # P->A and B->R
        s_m = cd * _port_area(lap - xo, rp)  # P->B and A->R
        sup = p_h if droop else p_set
        m_pa = _nozzle(s_p, sup, pa, ts if sup >= pa else ta, k, rg)
        m_pb = _nozzle(s_m, sup, pb, ts if sup >= pb else tb, k, rg)
        m_ae = _nozzle(s_m, pa, pe, ta if pa >= pe else ts, k, rg)
        m_be = _nozzle(s_p, pb, pe, tb if pb >= pe else ts, k, rg)
        h_a = m_pa * (ts if m_pa >= 0 else ta) - m_ae * (ta if m_ae >= 0 else ts)
        h_b = m_pb * (ts if m_pb >= 0 else tb) - m_be * (tb if m_be >= 0 else ts)
        fric = p.coulomb_friction * math.tanh(v / p.friction_sign_velocity) + p.viscous_friction * v
        m_reg = (p_set - p_h) / R_TRUE
        return [v, (area * (pa - pb) - fric) / p.mass,
                k * (rg * h_a - pa * area * v) / va, k * (rg * h_b + pb * area * v) / vb,
                m_pa - m_ae, m_pb - m_be,
                vv, -wv * wv * xv - 2.0 * zv * wv * vv + kv * wv * wv * (u - p.command_centre),
                rg * ts / V_HOSE * (m_reg - m_pa - m_pb) if droop else 0.0, u]

    y0 = centre + float(np.sum(amp * np.sin(ph)))
    p0 = 0.4e6
    va0 = area * y0 + p.dead_volume_a
    vb0 = area * (p.stroke - y0) + p.dead_volume_b
    s0 = [y0, 0.0, p0, p0, p0 * va0 / (rg * ts), p0 * vb0 / (rg * ts), 0.0, 0.0, p_set, 0.0]
    n = int(round(duration / DT)) + 1
    tt = DT * np.arange(n + 1)
    with np.errstate(over="ignore", invalid="ignore"):  # Radau's finite-difference Jacobian probes far
        sol = solve_ivp(rhs, (0.0, tt[-1]), s0, method="Radau", t_eval=tt, rtol=1e-7,
                        atol=[1e-10, 1e-8, 1, 1, 1e-11, 1e-11, 1e-10, 1e-7, 1, 1e-9])
    assert sol.success, sol.message
    u = np.diff(sol.y[-1]) / DT
    chans = {"y": sol.y[0, :n] + 1e-6 * rng.standard_normal(n),
             "pa": sol.y[2, :n] + 500.0 * rng.standard_normal(n),
             "pb": sol.y[3, :n] + 500.0 * rng.standard_normal(n)}
    rec = Record(DT, u, chans, f"independent rodless, {'drooping' if droop else 'stiff'} supply, seed {seed}")
    rec.port_pressure = sol.y[8, :n]
    return rec


@pytest.fixture(scope="module")
def base():
    return base_for(diagnosis_plant("rodless_cylinder"), None)


def _diagnose(base, droop):
    fit = rodless_record(base, droop, 1, 5.0)
    hold = rodless_record(base, droop, 1001, 3.0)
    return diagnose("rodless_cylinder", [fit], [hold], base=base, max_effects=1, maps=False), fit


def test_stiff_supply_record_is_effect_free(base):
    res, _ = _diagnose(base, False)
    assert res.verdict == "none", (res.verdict, res.reason, [(c.name, c.gain, c.reasons) for c in res.rounds[0].candidates])


def test_drooping_regulator_is_named_supply_droop(base):
    res, fit = _diagnose(base, True)
    # the record draws enough flow for the droop to matter: the port falls > 50 kPa at times
    assert base.supply_pressure - np.percentile(fit.port_pressure, 1) > 5e4
    assert [e["name"] for e in res.effects] == ["supply_droop"], (res.verdict, res.reason, res.effects)
    r = res.effects[0]["parameters"]["supply_line_resistance"]
    assert r == pytest.approx(R_TRUE, rel=0.3)
    assert res.verdict in ("named", "unexplained"), res.reason
