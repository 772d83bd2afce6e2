"""The dynamic seal-friction family (hydro_envs.laws.seal_friction) against independent truths.

* steady state: the seeds' static laws written out here (002 eq (1), 003 eq (11), 004 Table 2);
* stick: a body under a net force below breakaway holds, within the closed-form creep of the
  bristles; above breakaway it slides;
* pre-sliding hysteresis: the closed-form loop of the rate law under a displacement cycle;
* stick-slip of a mass-spring-belt system against an event-driven stick/slip switching model
  integrated by Radau (a different model of the same physics, which LuGre approaches as the
  bristles stiffen);
* dissipation: the friction never delivers power beyond what its bristles stored (and a
  constant micro-damping does, which shows the check can fail);
* the stiffness bound against the numerical Jacobian's eigenvalues;
* the quasi-static limit (``rate_cap``) against the law without it, both by Radau.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hydro_envs.laws import seal_friction as sf
from hydro_envs.laws.friction import dahl_friction_rate

FC, FS, VS, S2 = 40.0, 60.0, 0.01, 250.0


def law(v, z, g, s0, s1, vd, s2, n, cap=0.0):
    return sf.seal_friction(v, z, g, s0, s1, vd, s2, n, cap)


@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
def test_steady_state_is_the_seed_law(shape):
    """Driven at constant v from rest, the force settles on the seed's static law (sign, not tanh)."""
    s0, s1 = 1e6, 2e3
    curve = sf.stribeck_curve_exponential if shape == "exponential" else sf.stribeck_curve_gaussian
    for v in (-0.2, -0.02, -3e-3, 1e-4, 2e-3, 0.01, 0.05, 0.3):
        def rhs(t, y):
            return [law(v, y[0], curve(v, FC, FS, VS), s0, s1, VS, S2, 1)[1]]
        sol = solve_ivp(rhs, (0.0, 40.0 * FS / (s0 * abs(v))), [0.0], method="Radau", rtol=1e-10, atol=1e-14)
        f = law(v, sol.y[0, -1], curve(v, FC, FS, VS), s0, s1, VS, S2, 1)[0]
        if shape == "exponential":  # 002 eq (1) sliding branch / 004 Table 2, written out
            seed = (FC + (FS - FC) * math.exp(-abs(v) / VS)) * math.copysign(1.0, v) + S2 * v
        else:  # 003 eq (11) with sign(v)
            seed = (FC + (FS - FC) * math.exp(-((v / VS) ** 2))) * math.copysign(1.0, v) + S2 * v
        assert f == pytest.approx(seed, rel=1e-7, abs=1e-7)


def _body(force, g0, s0, s1, s2, m, n, t_end, t_ramp=0.0):
    """A body of mass m at rest, pushed by a force that ramps up over ``t_ramp`` and then stays
    constant; constant level g0 (slow motion)."""
    def rhs(t, y):
        x, v, z = y
        f, dz = law(v, z, g0, s0, s1, VS, s2, n)
        push = force * min(t / t_ramp, 1.0) if t_ramp > 0.0 else force
        return [v, (push - f) / m, dz]
    return solve_ivp(rhs, (0.0, t_end), [0.0, 0.0, 0.0], method="Radau", rtol=1e-9, atol=[1e-12, 1e-12, 1e-14],
                     dense_output=True)


@pytest.mark.parametrize("ratio", [0.3, 0.8, 0.95])
def test_body_below_breakaway_holds(ratio):
    """Under a force below breakaway, loaded slowly, the body creeps only while its bristles load,
    by the closed form ``-(g/sigma0) ln(1 - f/g)`` of the rate law under monotone loading, then
    holds still."""
    g0, s0, m = FS, 1e6, 12.3
    sol = _body(ratio * g0, g0, s0, sf.critical_micro_damping(s0, m), 0.0, m, 1, 3.0, t_ramp=2.0)
    x_half, x_end = sol.sol(2.5)[0], sol.y[0, -1]
    bound = -(g0 / s0) * math.log(1.0 - ratio)
    assert x_end == pytest.approx(bound, rel=0.05)
    assert abs(x_end - x_half) < 1e-3 * bound  # no drift once loaded
    assert abs(sol.y[1, -1]) < 1e-9


def test_body_above_breakaway_slides():
    g0, s0, m = FS, 1e6, 12.3
    sol = _body(1.2 * g0, g0, s0, sf.critical_micro_damping(s0, m), 0.0, m, 1, 0.2)
    # after breakaway the net force 0.2 g0 accelerates the body: x ~ 0.1 g0 t^2 / m
    assert sol.y[0, -1] > 0.5 * 0.1 * g0 * 0.2**2 / m


def test_presliding_hysteresis_loop_is_the_closed_form():
    """Displacement cycle x = A sin(w t) with A below the pre-sliding range, constant level g
    (slow: sigma1 and sigma2 play no part at zero micro-damping). Along a branch the rate law
    gives ``F = g (1 - (1 -+ F0/g) exp(-+sigma0 (x - x0) / g))``, so the periodic loop turns at
    ``F_t = g tanh(sigma0 A / g)`` and encloses the area of those exponential branches."""
    g, s0, amp, w = FS, 1e6, 40e-6, 2.0 * math.pi
    def rhs(t, y):
        v = amp * w * math.cos(w * t)
        return [sf.bristle_rate(v, y[0], g, s0, 1)]
    t = np.linspace(0.0, 8.0, 80001)
    sol = solve_ivp(rhs, (0.0, 8.0), [0.0], method="Radau", rtol=1e-11, atol=1e-16, t_eval=t)
    f = s0 * sol.y[0]
    x = amp * np.sin(w * t)
    last = t >= 7.0  # eighth cycle: periodic (the turning points converge by 0.26 per half cycle)
    f_t = g * math.tanh(s0 * amp / g)
    assert f[last].max() == pytest.approx(f_t, rel=1e-5)
    assert f[last].min() == pytest.approx(-f_t, rel=1e-5)
    # loop area: closed form of the branches, by quadrature
    xs = np.linspace(-amp, amp, 20001)
    up = g * (1.0 - (1.0 + f_t / g) * np.exp(-s0 * (xs + amp) / g))
    down = -up[::-1]
    area_closed = np.trapezoid(up - down, xs)
    xl, fl = x[last], f[last]
    area_sim = abs(np.sum(0.5 * (fl[1:] + fl[:-1]) * np.diff(xl)))
    assert area_closed > 0.05 * 2 * amp * f_t  # a real loop, not a line
    assert area_sim == pytest.approx(area_closed, rel=2e-3)


# ----------------------------------------------------------------- stick-slip against switching
M_SS, K_SS, VB = 1.0, 2.0, 0.1
FC_SS, FS_SS, VS_SS, S2_SS = 1.0, 1.5, 1e-3, 0.4  # Canudas de Wit et al. (1995) Table I levels


def _g_ss(vr):
    return sf.stribeck_curve_gaussian(vr, FC_SS, FS_SS, VS_SS)


def _switching_reference(t_end):
    """Event-driven stick/slip model: stuck on the belt (x' = v_b) while |k x| <= F_s; slipping
    with F = g(v_r) sgn(v_r) + sigma2 v_r, v_r = v_b - x'; integrated by Radau with events."""
    t, x, v, stuck = 0.0, 0.0, VB, True
    ts, xs = [0.0], [0.0]
    while t < t_end:
        if stuck:  # x grows at v_b until the spring reaches breakaway
            t_brk = t + (FS_SS / K_SS - x) / VB
            tt = np.linspace(t, min(t_brk, t_end), 200)
            ts += list(tt[1:])
            xs += list(x + VB * (tt[1:] - t))
            x, t, v, stuck = FS_SS / K_SS, t_brk, VB, False
            continue

        def rhs(_, y):  # slipping forward on the belt (v_r > 0) until the event; smooth across it
            vr = VB - y[1]
            return [y[1], (-K_SS * y[0] + _g_ss(vr) + S2_SS * vr) / M_SS]

        t_slip = t

        def stick_event(tt, y):  # armed once the slip is under way
            return VB - y[1] if tt > t_slip + 1e-3 else 1.0
        stick_event.terminal = True
        stick_event.direction = -1.0  # v_r falls back through 0 (the mass catches up with the belt)
        sol = solve_ivp(rhs, (t, t_end), [x, v - 1e-12], method="Radau", rtol=1e-10, atol=1e-12,
                        events=stick_event, dense_output=True, max_step=0.01)
        ts += list(sol.t[1:])
        xs += list(sol.y[0, 1:])
        t, x, v = sol.t[-1], sol.y[0, -1], VB
        if sol.status != 1:
            assert sol.status == 0, sol.message
            break
        stuck = abs(K_SS * x) <= FS_SS
        assert stuck, "the reference expects the mass to stick when it catches up with the belt"
    return np.array(ts), np.array(xs)


def _lugre_run(t_end, s0):
    s1 = math.sqrt(s0)  # Canudas de Wit et al. (1995)

    def rhs(_, y):
        x, v, z = y
        vr = VB - v
        f, dz = law(vr, z, _g_ss(vr), s0, s1, VS_SS, S2_SS, 1)
        return [v, (-K_SS * x + f) / M_SS, dz]
    t = np.linspace(0.0, t_end, int(t_end * 2000) + 1)
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, VB, 0.0], method="Radau", rtol=1e-9, atol=[1e-10, 1e-10, 1e-14],
                    t_eval=t)
    return sol.t, sol.y[0]


def _cycle(t, x):
    """Period (between the last two breakaways, the maxima of x) and peak-to-peak of the last cycle."""
    i = np.flatnonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:]))  + 1
    i = i[x[i] > 0.9 * x.max()]
    a, b = i[-2], i[-1]
    return t[b] - t[a], x[a:b + 1].max() - x[a:b + 1].min()


def test_stick_slip_matches_event_driven_switching():
    """Period and amplitude of the stick-slip cycle; LuGre's creep before breakaway shortens it
    by a margin that shrinks as the bristles stiffen (sigma0 1e5 -> 1e7 N/m: 2.2 % -> 0.1 %)."""
    t_end = 40.0
    tr, xr = _switching_reference(t_end)
    period_r, pp_r = _cycle(tr, xr)
    assert period_r > 5.0 and pp_r > 0.3  # a stick-slip cycle, not a steady slide
    period_soft, _ = _cycle(*_lugre_run(t_end, 1e5))
    period_l, pp_l = _cycle(*_lugre_run(t_end, 1e7))
    assert period_l == pytest.approx(period_r, rel=5e-3)
    assert pp_l == pytest.approx(pp_r, rel=5e-3)
    assert abs(period_l - period_r) < abs(period_soft - period_r)


# --------------------------------------------------------------------------- dissipation
def _dissipation_run(s1, vd, n=1):
    """Stick at F_s, then a jerk to 0.3 m/s and back: the bristles must never give back more
    than they stored."""
    s0 = 1e6
    g = lambda v: sf.stribeck_curve_exponential(v, FC, FS, VS)  # noqa: E731
    t = np.linspace(0.0, 0.06, 60001)
    v = np.where(t < 0.02, 1e-6, np.where(t < 0.04, 0.3, -0.3))
    z = FS / s0 * 0.999
    d = []
    for k in range(t.size - 1):
        f, dz = law(v[k], z, g(v[k]), s0, s1, vd, S2, n)
        d.append(sf.bristle_dissipation(v[k], z, f, dz, s0))
        h = t[k + 1] - t[k]
        # exact frozen-velocity update (the rate is linear in z for n = 1)
        a = s0 * abs(v[k]) / g(v[k])
        zs = g(v[k]) * math.copysign(1.0, v[k]) / s0
        z = zs + (z - zs) * math.exp(-a * h)
    return np.array(d)


def test_friction_never_delivers_power():
    s1 = sf.critical_micro_damping(1e6, 12.3)
    assert sf.micro_damping_is_dissipative(s1, VS, FC)
    assert _dissipation_run(s1, VS, 1).min() >= -1e-9
    # the check can fail: the same damping held constant gives power back after the breakaway
    assert not sf.micro_damping_is_dissipative(s1, 0.0, FC)
    assert _dissipation_run(s1, 0.0, 1).min() < -1.0


def test_exponent_two_is_001_dahl():
    s0, fc = 1e6, 26.0
    rng = np.random.default_rng(0)
    for _ in range(200):
        v, f = rng.normal(0, 0.05), rng.uniform(-1.5, 1.5) * fc
        assert s0 * sf.bristle_rate(v, f / s0, fc, s0, 2) == pytest.approx(dahl_friction_rate(v, f, fc, s0), rel=1e-12, abs=1e-9)
        d = sf.bristle_dissipation(v, f / s0, f, sf.bristle_rate(v, f / s0, fc, s0, 2), s0)
        assert d >= -1e-9


def test_no_dry_friction_leaves_viscous_only():
    assert law(0.1, 3e-5, 0.0, 1e6, 5e3, VS, S2, 1) == (S2 * 0.1, 0.0)


@pytest.mark.parametrize("n,cap", [(1, 0.0), (2, 0.0), (1, 4000.0), (2, 4000.0)])
def test_block_rate_bound_covers_the_jacobian(n, cap):
    rng = np.random.default_rng(1)
    s0, m, c = 1e6, 12.3, 250.0
    s1 = 0.0 if n == 2 else sf.critical_micro_damping(s0, m)
    g = lambda v: sf.stribeck_curve_exponential(v, FC, FS, VS)  # noqa: E731
    ratio = sf.stribeck_slope_ratio_bound(FC, FS, "exponential")
    for _ in range(400):
        v = rng.choice([rng.normal(0, 1e-3), rng.normal(0, 0.3)])
        z = rng.uniform(-1, 1) * FS / s0

        def f(y):
            fr, dz = law(y[0], y[1], g(y[0]), s0, s1, VS, 0.0, n, cap)
            return np.array([(-fr - c * y[0]) / m, dz])
        y0 = np.array([v, z])
        jac = np.empty((2, 2))
        for j, h in enumerate((1e-9 + 1e-7 * abs(v), 1e-12)):
            e = np.zeros(2)
            e[j] = h
            jac[:, j] = (f(y0 + e) - f(y0 - e)) / (2 * h)
        lam = np.abs(np.linalg.eigvals(jac)).max()
        bound = sf.bristle_block_rate_bound(v, z, min(g(v), FC), ratio, s0, s1, VS, c, m, n, cap)
        assert lam <= bound * (1 + 1e-6) + 1e-6
        if cap > 0.0:
            assert bound <= sf.bristle_stiffness_bound(FC, FS, ratio, s0, s1, VS, c, m, n, cap, 1.0) * (1 + 1e-9)


# ------------------------------------------------------------------ the quasi-static limit
CAP = 4000.0


def test_quasi_static_limit_keeps_the_steady_state_and_is_dissipative():
    s0, s1 = 2e6, sf.critical_micro_damping(2e6, 12.3)
    rng = np.random.default_rng(2)
    for v in (-0.8, -0.2, 0.09, 0.5, 1.2):
        g = sf.stribeck_curve_exponential(v, FC, FS, VS)
        f, dz = law(v, g * math.copysign(1.0, v) / s0, g, s0, s1, VS, S2, 1, CAP)
        assert abs(dz) <= 1e-15 * abs(v)  # zero to rounding
        assert f == pytest.approx(g * math.copysign(1.0, v) + S2 * v, rel=1e-12)
    for n in (1, 2):
        for _ in range(3000):
            v = rng.normal(0.0, 0.5)
            z = rng.uniform(-2.0, 2.0) * FS / s0
            g = sf.stribeck_curve_exponential(v, FC, FS, VS)
            f, dz = law(v, z, g, s0, s1 if n == 1 else 0.0, VS, S2, n, CAP)
            assert sf.bristle_dissipation(v, z, f, dz, s0) >= -1e-9 * (abs(f * v) + 1.0)
    # LuGre exactly below the speed where the relaxation reaches the cap
    v = 0.5 * CAP * FC / s0
    for z in (-FS / s0, 0.0, 0.5 * FS / s0):
        g = sf.stribeck_curve_exponential(v, FC, FS, VS)
        assert law(v, z, g, s0, s1, VS, S2, 1, CAP) == law(v, z, g, s0, s1, VS, S2, 1, 0.0)


def _forced_body(cap, t_end=0.6):
    """12.3 kg on LuGre seals (servo-like: F_S/sigma0 = 30 um) under a force that swings it
    through reversals at up to ~0.5 m/s, with fast accelerations (up to ~100 m/s^2)."""
    s0, m = 2e6, 12.3
    s1 = sf.critical_micro_damping(s0, m)

    def push(t):
        return 1200.0 * math.sin(2 * math.pi * 3.0 * t) + 300.0 * math.sin(2 * math.pi * 17.0 * t)

    def rhs(t, y):
        g = sf.stribeck_curve_exponential(y[1], FC, FS, VS)
        f, dz = law(y[1], y[2], g, s0, s1, VS, S2, 1, cap)
        return [y[1], (push(t) - f - 2000.0 * y[1]) / m, dz]
    t = np.linspace(0.0, t_end, 6001)
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, 0.0, 0.0], method="Radau", rtol=1e-10,
                    atol=[1e-12, 1e-11, 1e-15], t_eval=t)
    return sol.y


def test_quasi_static_limit_against_lugre():
    """The capped law follows plain LuGre (Radau, rtol 1e-10) through reversals at speed: the
    position differs by far less than a 1 um scale count, the friction force only briefly."""
    y_cap, y_lugre = _forced_body(CAP), _forced_body(0.0)
    assert np.abs(y_lugre[1]).max() > 0.3  # fast enough for the cap to act (above 0.08 m/s)
    assert np.abs(y_cap[0] - y_lugre[0]).max() < 0.2e-6
    assert np.abs(y_cap[1] - y_lugre[1]).max() < 2e-4


def _composed(v, z, g, s0, s1, vd, s2, n, cap):
    """The family from its parts (bristle_rate, quasi_static_weight, micro_damping)."""
    if not g > 0.0:
        return s2 * v, 0.0
    eps = sf.quasi_static_weight(v, z, g, s0, n, cap)
    dz = eps * sf.bristle_rate(v, z, g, s0, n)
    f = s0 * z if eps == 1.0 else eps * s0 * z + (1.0 - eps) * math.copysign(g, v)
    return f + sf.micro_damping(v, s1, vd) * dz + s2 * v, dz


@pytest.mark.parametrize("n", [1, 2])
def test_written_out_law_equals_its_parts(n):
    """seal_friction is written out once for speed; it is the composition of the documented
    parts to rounding, at rest, in pre-sliding, through the dip and above the rate cap."""
    rng = np.random.default_rng(7)
    s0, s1 = 2e6, sf.critical_micro_damping(2e6, 12.3) if n == 1 else 0.0
    for _ in range(5000):
        v = float(rng.choice([0.0, rng.normal(0.0, 0.003), rng.normal(0.0, 0.5)]))
        z = float(rng.uniform(-1.5, 1.5) * FS / s0)
        g = sf.stribeck_curve_exponential(v, FC, FS, VS)
        got = sf.seal_friction(v, z, g, s0, s1, VS, S2, n, CAP)
        want = _composed(v, z, g, s0, s1, VS, S2, n, CAP)
        assert got[0] == pytest.approx(want[0], rel=1e-12, abs=1e-9)
        assert got[1] == pytest.approx(want[1], rel=1e-12, abs=1e-15)
