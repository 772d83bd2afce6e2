"""Diagnosis on records from a generator independent of the workflow's own simulator: a rigid
axis (the slider's physics: mass, viscous and tanh-regularised Coulomb friction, 002 eq (1))
integrated by scipy's Radau under a PD position loop, with or without an effect: mechanical
backlash between drive and load (in the catalogue: the slider's driven body behind a play; also
diagnosed with the catalogue minus backlash, as an effect outside it), a position-dependent
spring force (e.g. a cable chain, outside the catalogue), a worn-seal band of doubled Coulomb
friction (position-dependent friction, outside the catalogue). None of the workflow's kernels,
controllers or noise code is used to make these records.

Expected: effects outside the catalogue in use -> ``unexplained`` (or ambiguous), never a
confident wrong name; backlash with the whole catalogue -> named, its play recovered although
the generator's contact (2e5 N/m, 100 N s/m viscous, engaged over 10 um) differs from the
model's (1e6 N/m, 240 N s/m); an effect-free record with mains hum and sensor offsets ->
``none``; an in-catalogue effect -> named with the residual left near the noise floor. Also:
the noise floor and the residual per step are reported with units, and a base fit that cannot
work is an error that says why (no sentinel value reported as a shrink).
"""

from __future__ import annotations

import functools
import json
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from identification.diagnosis import DiagnosisFitError, Record, diagnose, diagnosis_plant
from identification.diagnosis.floor import UNEXPLAINED_FACTOR
from identification.diagnosis.synthetic import base_for

DT = 1e-3
# rigid axis (the slider's nominal values, hydro_envs/plants/slider/params.py)
M, B, FC, V_EPS, CENTRE = 1.0, 20.0, 10.0, 5e-4, 0.1
X_NOISE = 1e-6  # m, encoder noise (std)


def _reference(rng):
    """Position reference r(t) and r'(t): a sum of sines of 0.15-4 Hz, peak ~25 mm."""
    f = np.array([0.15, 0.4, 0.9, 1.7, 2.9, 4.0])
    a = 0.018 / (1 + 2 * f)
    ph = rng.uniform(0, 2 * np.pi, f.size)
    w = 2 * np.pi * f
    return (lambda t: CENTRE + np.sum(a * np.sin(w * t + ph))), (lambda t: np.sum(a * w * np.cos(w * t + ph)))


def _friction(v, fc, fs=None, vs=None):
    """Coulomb friction ``fc`` with the soft sign tanh(v / V_EPS); with ``fs`` and ``vs`` the
    Stribeck curve of 002 eq (1), ``fc + (fs - fc) exp(-|v| / vs)``, in its place."""
    level = fc if fs is None else fc + (fs - fc) * np.exp(-abs(v) / vs)
    return level * np.tanh(v / V_EPS)


#: the worn-seal band [m] (lower, upper edge, edge width): 7 mm, 20 % of the 35 mm the axis travels
WORN_BAND = (0.095, 0.102, 2e-4)


def _worn_seal_factor(x):
    """1 outside :data:`WORN_BAND`, 2 inside it (smooth edges)."""
    lo, hi, w = WORN_BAND
    return 1.0 + 0.5 * (np.tanh((x - lo) / w) - np.tanh((x - hi) / w))


def axis_record(effect: str | None, seed: int, duration: float, *, fc: float = FC, hum: float = 0.0,
                offset: float = 0.0, stribeck: tuple[float, float] | None = None) -> Record:
    """Closed-loop record of the rigid axis: a continuous PD loop (40 rad/s, zeta 0.7, on the
    load's position and velocity) integrated with the plant by Radau in one solve; the recorded
    force of sample k is the mean force over [t_k, t_k+1) (an integral state), so a replay that
    holds it over the interval applies the same impulse. ``effect``: None, ``"backlash"`` (0.8 kg
    drive + 0.2 kg load through a +-0.1 mm gap, contact 2e5 N/m; the load is measured) or
    ``"spring"`` (a 300 N/m spring about the stroke centre) or ``"worn_seal"`` (the Coulomb level
    doubled over a band of 7 mm, 20 % of the travel, :data:`WORN_BAND`). Encoder noise X_NOISE on the
    recorded position; ``hum``: 50 Hz amplitude [m] on the recorded position and ``hum`` * 1e4 N
    on the recorded force (pickup in the cables); ``offset``: a zero error [m] of the recorded
    position."""
    rng = np.random.default_rng(seed)
    r, dr = _reference(rng)
    gap, k_c, c_c, m1, m2 = 1e-4, 2e5, 100.0, 0.8, 0.2
    k_s = 300.0 if effect == "spring" else 0.0

    def force(t, x, v):
        return float(np.clip(M * (40.0**2 * (r(t) - x) + 2 * 0.7 * 40.0 * (dr(t) - v)), -100.0, 100.0))

    if effect == "backlash":
        def rhs(t, y):
            x1, v1, x2, v2, _ = y
            f = force(t, x2, v2)
            d = x1 - x2
            engaged = 0.5 * (1 + np.tanh((abs(d) - gap) / 1e-5))
            fcpl = k_c * (max(d - gap, 0.0) + min(d + gap, 0.0)) + c_c * (v1 - v2) * engaged
            a1 = (f - B * m1 * v1 - _friction(v1, fc * m1) - fcpl) / m1
            a2 = (fcpl - B * m2 * v2 - _friction(v2, fc * m2)) / m2
            return [v1, a1, v2, a2, f]
        y0, ipos = [CENTRE, 0.0, CENTRE, 0.0, 0.0], 2
    else:
        worn = effect == "worn_seal"

        def rhs(t, y):
            x, v, _ = y
            f = force(t, x, v)
            fc_x = fc * _worn_seal_factor(x) if worn else fc
            fric = _friction(v, fc_x) if stribeck is None else _friction(v, fc_x, *stribeck)
            return [v, (f - B * v - fric - k_s * (x - CENTRE)) / M, f]
        y0, ipos = [CENTRE, 0.0, 0.0], 0
    n = int(round(duration / DT)) + 1
    tt = DT * np.arange(n + 1)
    with np.errstate(over="ignore"):  # the finite-difference Jacobian probes far in the stiff contact
        sol = solve_ivp(rhs, (0.0, tt[-1]), y0, method="Radau", t_eval=tt, rtol=1e-6, atol=1e-10)
    assert sol.success, sol.message
    x = sol.y[ipos, :n]
    f = np.diff(sol.y[-1]) / DT
    xs = x + X_NOISE * rng.standard_normal(n) + hum * np.sin(2 * np.pi * 50 * tt[:n]) + offset
    fs = f + hum * 1e4 * np.sin(2 * np.pi * 50 * tt[:n] + 1.0)
    return Record(DT, fs, {"x": xs}, f"axis {effect or 'effect-free'} seed {seed}")


def _run(effect, seed, *, base_effect=None, records=False, effects=None, **kw):
    spec = diagnosis_plant("slider")
    fit = axis_record(effect, seed, 5.0, **kw)
    hold = axis_record(effect, seed + 1000, 3.0, **kw)
    base = base_for(spec, base_effect)
    res = diagnose("slider", [fit], [hold], base=base, max_effects=2, maps=False, effects=effects)
    return (res, fit, hold) if records else res


#: the slider's catalogue without backlash: the backlash record then carries an effect outside it
WITHOUT_BACKLASH = ["coulomb", "stribeck", "force_offset", "sensor_delay"]


@functools.lru_cache(maxsize=None)
def backlash_outside_the_catalogue():
    """(result, fit record, held-out record) of the backlash record diagnosed with
    :data:`WITHOUT_BACKLASH`: run once per session, read by this module, ``test_diagnosis_threshold``
    and ``test_diagnosis_stable`` (none of them changes it)."""
    return _run("backlash", 1, records=True, effects=WITHOUT_BACKLASH)


@pytest.fixture(scope="module")
def backlash_run():
    return backlash_outside_the_catalogue()


@pytest.fixture(scope="module")
def backlash(backlash_run):
    return backlash_run[0]


@pytest.mark.slow  # 20-80 s: run by make test-all
def test_backlash_is_named_with_its_play():
    res = _run("backlash", 1)
    assert res.verdict == "named" and [e["name"] for e in res.effects] == ["backlash"], (res.verdict, res.reason)
    got = res.effects[0]["parameters"]
    assert got["backlash_gap"] == pytest.approx(1e-4, rel=0.15)
    assert got["load_mass_fraction"] == pytest.approx(0.2, rel=0.25)
    assert res.residual[-1]["floors"]["x"] <= UNEXPLAINED_FACTOR


def test_backlash_outside_the_catalogue_in_use_is_unexplained_not_named(backlash):
    res = backlash
    assert res.verdict in ("unexplained", "ambiguous"), (res.verdict, res.reason, res.effects)
    if res.verdict == "unexplained":
        assert res.mismatch["channel"] == "x" and res.mismatch["unit"] == "m"
        assert res.mismatch["ratio"] > UNEXPLAINED_FACTOR
        assert res.mismatch["worst_region"] and res.mismatch["worst_band"]
        assert "noise floors" in res.reason and "channel 'x'" in res.reason


@pytest.mark.slow  # 120-210 s: the Stribeck candidate's refits at the base fit's 0.1 kg mass bound
def test_spring_is_unexplained_not_named():
    res = _run("spring", 2)
    assert res.verdict in ("unexplained", "ambiguous"), (res.verdict, res.reason, res.effects)


@pytest.mark.slow  # 15-30 s
def test_position_dependent_friction_is_unexplained_not_averaged_into_one_coulomb_level():
    """A worn-seal band (Coulomb friction doubled over 7 mm, 20 % of the travel) beside the base
    model's Coulomb friction: no single Coulomb level or other catalogue effect explains it, so
    nothing is named and the verdict says so (the issue's record averaged it into one Coulomb
    level just under a fixed threshold)."""
    res = _run("worn_seal", 6)
    assert res.verdict in ("unexplained", "ambiguous"), (res.verdict, res.reason, res.effects)
    assert not res.effects, res.effects
    assert res.residual[-1]["floors"]["x"] > UNEXPLAINED_FACTOR


@pytest.mark.slow  # 35-105 s
@pytest.mark.parametrize("fs, vs", [(20.0, 5e-3), (16.0, 2e-3)])
def test_stribeck_on_an_independent_axis_record_is_named_within_tolerance(fs, vs):
    """Stribeck friction of 002 eq (1) on the Radau axis (20 s fit, 10 s held out), the base
    model with its Coulomb level: named alone, F_s and v_s within 25 %, the residual explained.
    The free run replays the recorded force, which peaks just above the axis' breakaway force,
    so the output-error cost is a cliff across the ridge of equal breakaway force (a true
    model's basin is ~0.5 % of it wide); the refit starts from the best point of scans along
    that ridge (``stribeck_starts`` of the slider). Two failures this test caught: from the
    catalogue start the refit stopped at (19.6 N, 4.1 mm/s) with a spurious delay, and a window
    start in a stick-slip transient whose velocity the quadratic 20 ms estimate read 5 % low
    made the true model stick where the axis slid (one window of 39 held all of the truth's
    cost)."""
    spec = diagnosis_plant("slider")
    fit = axis_record(None, 6, 20.0, stribeck=(fs, vs))
    hold = axis_record(None, 1006, 10.0, stribeck=(fs, vs))
    res = diagnose("slider", [fit], [hold], base=base_for(spec, "stribeck"), maps=False)
    assert [e["name"] for e in res.effects] == ["stribeck"], (res.verdict, res.effects)
    got = res.effects[0]["parameters"]
    assert got["static_friction"] == pytest.approx(fs, rel=0.25)
    assert got["stribeck_velocity"] == pytest.approx(vs, rel=0.25)
    assert res.verdict == "named" and res.residual[-1]["floors"]["x"] <= UNEXPLAINED_FACTOR


def test_effect_free_record_with_hum_and_offset_gives_none():
    res = _run(None, 3, hum=1e-6, offset=2e-3)
    assert res.verdict == "none", (res.verdict, res.reason, res.effects)
    assert res.residual[-1]["floors"]["x"] <= UNEXPLAINED_FACTOR


def test_in_catalogue_coulomb_is_named_and_leaves_little():
    res = _run(None, 4, base_effect="coulomb", fc=8.0)
    assert res.verdict == "named" and res.effects[0]["name"] == "coulomb", (res.verdict, res.reason)
    assert res.effects[0]["parameters"]["coulomb_friction"] == pytest.approx(8.0, rel=0.2)
    before, after = res.residual[0], res.residual[-1]
    assert before["step"] == "base model" and after["step"] == "coulomb"
    assert after["rms"]["x"] < before["rms"]["x"] and after["floors"]["x"] <= UNEXPLAINED_FACTOR


def test_report_carries_floor_residual_and_reason(backlash):
    from identification.diagnosis.cli import summary_text

    d = json.loads(json.dumps(backlash.to_json_dict(), allow_nan=False))
    fl = d["noise_floor"]["x"]
    assert fl["unit"] == "m" and fl["floor"] > 0 and fl["sensor_noise"] == pytest.approx(X_NOISE, rel=0.3)
    assert d["residual"][0]["step"] == "base model" and d["residual"][0]["rms"]["x"] > 0
    assert d["reason"] and d["unexplained_factor"] == UNEXPLAINED_FACTOR
    text = summary_text(backlash)
    assert "noise floor" in text and " m " in text and "reason:" in text


def test_markdown_report_says_where_the_mismatch_remains(backlash_run, tmp_path):
    from identification.diagnosis.report import write_report

    res, fit, hold = backlash_run
    md = write_report(res, diagnosis_plant("slider"), [fit], [hold], tmp_path).read_text()
    assert "## Noise floor and held-out residual" in md and "| base model |" in md
    assert "Reason: " in md
    if res.verdict == "unexplained":
        assert "Where the mismatch remains: channel `x`" in md and "m/s" in md


def test_a_failed_score_is_an_error_or_inf_never_a_sentinel():
    """A free run that is not finite scores inf (not a large number reported as a shrink); a
    channel constant over the scored samples is a data error naming the channel."""
    from identification.diagnosis import DiagnosisDataError
    from identification.diagnosis.fitting import _nrmse, _pooled_score

    y = np.sin(np.linspace(0, 6, 200))
    e = SimpleNamespace(weights=None, outputs={"x": y, "p": np.ones(200)}, dt=1e-3, name="w1")
    nr = _nrmse([e], [{"x": np.full(200, np.nan)}])
    assert nr == {"x": np.inf}
    with pytest.raises(DiagnosisDataError, match="channel 'p' is constant"):
        _nrmse([e], [{"p": np.zeros(200)}])
    with pytest.raises(DiagnosisDataError, match="channel 'x' is constant over the held-out windows other than"):
        _pooled_score([{"x": (1.0, 2.0)}, {"x": (1.0, 0.0)}], drop=0)


def test_a_base_fit_that_does_not_run_is_an_error_that_says_why():
    from identification.diagnosis.models import Model
    from identification.diagnosis.workflow import _check_base_fit

    spec = diagnosis_plant("slider")
    m = Model(base_for(spec, None))
    fit = SimpleNamespace(model=m, result=SimpleNamespace(nrmse={"x": float("inf")}))
    with pytest.raises(DiagnosisFitError, match=r"base fit of slider failed.*\['x'\].*mass = 1"):
        _check_base_fit(spec, fit, m, [], "fit")
    _check_base_fit(spec, SimpleNamespace(model=m, result=SimpleNamespace(nrmse={"x": 0.1})), m, [], "fit")


def test_a_winner_correlated_with_an_earlier_effect_is_ambiguous():
    """Identifiability of a multi-effect model: the winner's parameter correlated at 0.999 with
    one of an effect named earlier (not its prerequisite) -> ambiguous, both listed; with its
    prerequisite (Coulomb for the Stribeck levels) or at 0.96 -> kept, the pair noted."""
    from identification.diagnosis.decision import check_correlated

    spec = diagnosis_plant("slider")

    def winner(name, pairs):
        fit = SimpleNamespace(result=SimpleNamespace(correlated_pairs=pairs))
        return SimpleNamespace(name=name, fit=fit, reasons=[])

    w = winner("force_offset", [("force_offset", "stribeck_velocity", 0.999)])
    dec, sep = check_correlated(spec, w, ["stribeck"], "force_offset", "")
    assert dec == "ambiguous: force_offset vs stribeck" and "stribeck" in sep
    w = winner("force_offset", [("coulomb_friction", "force_offset", -0.999)])
    assert check_correlated(spec, w, ["coulomb"], "force_offset", "")[0] == "ambiguous: force_offset vs coulomb"
    w = winner("stribeck", [("coulomb_friction", "static_friction", 0.999)])
    assert check_correlated(spec, w, ["coulomb"], "stribeck", "")[0] == "stribeck"
    w = winner("force_offset", [("force_offset", "stribeck_velocity", 0.96)])
    assert check_correlated(spec, w, ["stribeck"], "force_offset", "")[0] == "force_offset"
    assert "correlated with stribeck_velocity of stribeck" in w.reasons[0]


def test_final_model_lists_every_fitted_parameter_with_its_uncertainty(backlash):
    """The report's final model: every base-fit parameter (and each named effect's) with a
    finite standard error and its unit; the on-bound flag is set exactly on a bound."""
    from identification.diagnosis.cli import summary_text
    from identification.diagnosis.final_model import on_bound

    rows = {r["name"]: r for r in backlash.final_model_table}
    spec = diagnosis_plant("slider")
    assert set(spec.base_fit) <= set(rows), (spec.base_fit, list(rows))
    for e in backlash.effects:
        assert set(e["parameters"]) <= set(rows)
    for n in spec.base_fit:
        r = rows[n]
        assert r["role"] == "base" and np.isfinite(r["value"]) and np.isfinite(r["std_error"]) and r["unit"], r
        assert r["lower"] <= r["value"] <= r["upper"]
    d = json.loads(json.dumps(backlash.to_json_dict(), allow_nan=False))
    assert [r["name"] for r in d["final_model"]] == list(rows)
    assert "final model (value +- standard error):" in summary_text(backlash)
    assert on_bound(1.0, 1.0, 10.0) and on_bound(10.0, 1.0, 10.0) and not on_bound(3.0, 1.0, 10.0)
    assert on_bound(-1.0, -1.0, 1.0) and not on_bound(0.0, -1.0, 1.0)


def test_report_figures_have_units_on_every_axis_and_tell_base_from_final(backlash_run, tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    from identification.diagnosis.report import write_report

    seen: list[Figure] = []
    orig = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: (seen.append(self), orig(self, *a, **k))[1])
    res, fit, hold = backlash_run
    md = write_report(res, diagnosis_plant("slider"), [fit], [hold], tmp_path).read_text()
    assert "## Final model" in md and "| on a bound |" in md
    assert len(seen) == 3
    for fig in seen:
        for ax in fig.axes:
            assert "[" in ax.get_ylabel(), ax.get_ylabel()
            if ax.get_xlabel():
                assert "[" in ax.get_xlabel(), ax.get_xlabel()
            styles = {(ln.get_color(), ln.get_linestyle()) for ln in ax.get_lines() if "model" in ln.get_label()}
            assert len(styles) == len([ln for ln in ax.get_lines() if "model" in ln.get_label()]), styles
        assert all(ax.get_xlabel() for ax in fig.axes[-1:])
