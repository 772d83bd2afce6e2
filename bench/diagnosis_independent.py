"""Diagnosis on records from generators independent of the workflow, at 20 s fit + 10 s held out.

    python bench/diagnosis_independent.py [--cases rodless,servo,...] [--fit 20] [--hold 10]

The generators live in ``tests/`` (each writes its plant's equations out again and integrates
them with scipy's Radau; none of the workflow's kernels, controllers or noise code):

* ``tests/test_diagnosis_unexplained.py``: a rigid axis under a PD loop (the slider's physics),
  effect-free with mains hum and a position offset, with Coulomb friction, with Stribeck friction
  (002 eq (1)), with a backlash
  (diagnosed with the whole catalogue and with the catalogue minus backlash, where it is an
  effect outside it), with a position-dependent spring and with a worn-seal band of doubled
  Coulomb friction (both outside the catalogue);
* ``tests/test_diagnosis_base_from_data.py``: a 60 kg axis with Coulomb friction and a constant
  force, diagnosed with the base model read off the record (the last third held out);
* ``tests/test_diagnosis_supply_droop.py``: the servo cylinder (002 eq (8)) and the pneumatic
  rodless cylinder (004) with a stiff supply and with a supply that droops through a hose (the
  hose's lag is outside the catalogue's static droop); with Coulomb and Stribeck friction (the
  servo's seals LuGre with 002 eq (1) as steady state, the rodless cylinder's the static curve of
  004 eq (1), or LuGre bristles: ``presliding``); friction and the drooping supply at once.

Each case runs :func:`identification.diagnosis.diagnose` with its default ``max_effects`` (3)
and prints the verdict, the effects named, what is expected, whether the outcome is right
(named right, ``none`` on effect-free data, an off-catalogue effect ``unexplained`` or
ambiguous, never another name), the fitted values of the effects named, and the seconds the
diagnosis took (the record's generation not included) against the 60 s target. Prints only; no
pass/fail exit status.
"""

from __future__ import annotations

import argparse
import dataclasses
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from identification.diagnosis import DiagnosisDataError, DiagnosisFitError, diagnose, diagnosis_plant  # noqa: E402
from identification.diagnosis.synthetic import base_for  # noqa: E402

TARGET_SECONDS = 60.0


def _axis(effect, seed, fit, hold, **kw):
    from test_diagnosis_unexplained import axis_record

    return axis_record(effect, seed, fit, **kw), axis_record(effect, seed + 1000, hold, **kw)


def _cases(fit: float, hold: float):
    """name -> (plant, make records, diagnose keywords, expected names, off-catalogue?)."""
    from test_diagnosis_base_from_data import heavy_axis_record
    from test_diagnosis_supply_droop import rodless_record, servo_record
    from test_diagnosis_unexplained import WITHOUT_BACKLASH

    slider = diagnosis_plant("slider")
    servo = base_for(diagnosis_plant("servo_cylinder"), None)
    # the rodless generator's chambers are adiabatic (004 eqs (8)-(13)): so is its base model, as in the tests
    rodless = dataclasses.replace(base_for(diagnosis_plant("rodless_cylinder"), None), wall_heat_transfer_coefficient=0.0)
    heavy = (fit + hold) / fit
    out = {
        "axis effect-free, hum and offset": (
            "slider", lambda: _axis(None, 3, fit, hold, hum=1e-6, offset=2e-3),
            dict(base=base_for(slider, None)), [], False),
        "axis coulomb 8 N": (
            "slider", lambda: _axis(None, 4, fit, hold, fc=8.0),
            dict(base=base_for(slider, "coulomb")), ["coulomb"], False),
        "axis backlash": (
            "slider", lambda: _axis("backlash", 1, fit, hold),
            dict(base=base_for(slider, None)), ["backlash"], False),
        "axis backlash, catalogue without it": (
            "slider", lambda: _axis("backlash", 1, fit, hold),
            dict(base=base_for(slider, None), effects=WITHOUT_BACKLASH), [], True),
        "axis spring (outside the catalogue)": (
            "slider", lambda: _axis("spring", 2, fit, hold),
            dict(base=base_for(slider, None)), [], True),
        "axis stribeck 20 N, 5 mm/s": (
            "slider", lambda: _axis(None, 6, fit, hold, stribeck=(20.0, 5e-3)),
            dict(base=base_for(slider, "stribeck")), ["stribeck"], False),
        "axis stribeck 16 N, 2 mm/s": (
            "slider", lambda: _axis(None, 6, fit, hold, stribeck=(16.0, 2e-3)),
            dict(base=base_for(slider, "stribeck")), ["stribeck"], False),
        "axis worn-seal band (outside the catalogue)": (
            "slider", lambda: _axis("worn_seal", 6, fit, hold),
            dict(base=base_for(slider, None)), [], True),
        "heavy axis coulomb + force, base from data": (
            "slider", lambda: ([heavy_axis_record(11, fit + hold, f0=-3.0)], None),
            dict(holdout_fraction=1 - 1 / heavy), ["coulomb", "force_offset"], False),
    }
    servo_fric = {"servo coulomb 60 N": ("coulomb", dict(fc=60.0), ["coulomb"]),
                  "servo stribeck 80 N, 4 mm/s": ("stribeck", dict(stribeck=(80.0, 4e-3)), ["stribeck"]),
                  "servo stribeck 80 N, 1 mm/s": ("stribeck", dict(stribeck=(80.0, 1e-3)), ["stribeck"])}
    for name, (hidden, kw, expected) in servo_fric.items():
        b = base_for(diagnosis_plant("servo_cylinder"), hidden)
        out[name] = ("servo_cylinder", _friction_records(servo_record, b, kw, fit, hold), dict(base=b),
                     expected, False)
    rodless_fric = {"rodless coulomb 20 N": ("coulomb", dict(fc=20.0), ["coulomb"]),
                    "rodless stribeck 35.5 N, 3.27 mm/s": ("stribeck", dict(stribeck=(35.5, 3.27e-3)), ["stribeck"]),
                    "rodless stribeck 35.5 N, 1 mm/s": ("stribeck", dict(stribeck=(35.5, 1e-3)), ["stribeck"]),
                    "rodless presliding 1e5 N/m": ("presliding", dict(bristle_stiffness=1e5), ["presliding"])}
    for name, (hidden, kw, expected) in rodless_fric.items():
        b = dataclasses.replace(base_for(diagnosis_plant("rodless_cylinder"), hidden), wall_heat_transfer_coefficient=0.0)
        out[name] = ("rodless_cylinder", _friction_records(rodless_record, b, kw, fit, hold), dict(base=b),
                     expected, False)
    # two effects at once: friction and a drooping supply; through the 1 L hose (29 ms lag) and the
    # rodless 5 mL hose (24 ms) the lag is outside the catalogue, through a 10 mL servo hose (0.3 ms) not
    servo_stribeck = base_for(diagnosis_plant("servo_cylinder"), "stribeck")
    two = {"servo stribeck 80 N, 4 mm/s + droop, 1 L hose": (
               "servo_cylinder", servo_record, servo_stribeck, dict(stribeck=(80.0, 4e-3)), True),
           "servo stribeck 80 N, 4 mm/s + droop, 10 mL hose": (
               "servo_cylinder", servo_record, servo_stribeck, dict(stribeck=(80.0, 4e-3), hose_volume=1e-5), False),
           "rodless coulomb 20 N + droop, 5 mL hose": (
               "rodless_cylinder", rodless_record,
               dataclasses.replace(base_for(diagnosis_plant("rodless_cylinder"), "coulomb"),
                                   wall_heat_transfer_coefficient=0.0),
               dict(fc=20.0), True)}
    for name, (plant, make, b, kw, off) in two.items():
        expected = ["stribeck" if "stribeck" in kw else "coulomb", "supply_droop"]
        out[name] = (plant, _friction_records(make, b, kw, fit, hold, droop=True), dict(base=b), expected, off)
    for plant, short, make, base in (("servo_cylinder", "servo", servo_record, servo),
                                     ("rodless_cylinder", "rodless", rodless_record, rodless)):
        for droop in (False, True):
            name = f"{short} {'drooping supply through a hose' if droop else 'stiff supply'}"
            out[name] = (plant, _supply_records(make, base, droop, fit, hold), dict(base=base),
                         ["supply_droop"] if droop else [], droop)
    return out


def _friction_records(make, base, kw, fit: float, hold: float, droop: bool = False):
    return lambda: ([make(base, droop, 2, fit, **kw)], [make(base, droop, 1002, hold, **kw)])


def _supply_records(make, base, droop: bool, fit: float, hold: float):
    return lambda: (make(base, droop, 1, fit), make(base, droop, 1001, hold))


def _right(verdict: str, named: list[str], expected: list[str], off_catalogue: bool) -> bool:
    """Named right (the expected effects, in any order), ``none`` on effect-free data; with an
    effect outside the catalogue ``unexplained`` or ambiguous, naming at most the expected ones."""
    if off_catalogue:
        return verdict in ("unexplained", "ambiguous") and set(named) <= set(expected)
    if not expected:
        return verdict == "none"
    return verdict in ("named", "unexplained") and sorted(named) == sorted(expected)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="", help="comma-separated substrings of case names (default: all)")
    ap.add_argument("--fit", type=float, default=20.0, help="seconds of fit data (default 20)")
    ap.add_argument("--hold", type=float, default=10.0, help="seconds of held-out data (default 10)")
    args = ap.parse_args(argv)
    want = [w.strip() for w in args.cases.split(",") if w.strip()]
    rows = []
    for name, (plant, make, kw, expected, off) in _cases(args.fit, args.hold).items():
        if want and not any(w in name for w in want):
            continue
        fit, hold = make()
        fit = fit if isinstance(fit, list) else [fit]
        hold = None if hold is None else (hold if isinstance(hold, list) else [hold])
        t0 = time.perf_counter()
        try:
            res = diagnose(plant, fit, hold, maps=False, **kw)
        except (DiagnosisDataError, DiagnosisFitError) as err:  # data too short or poor: said, not fitted
            print(f"{name:44s} error: {err}", flush=True)
            rows.append((name, "error", [], expected, False, time.perf_counter() - t0))
            continue
        secs = time.perf_counter() - t0
        verdict = res.verdict
        named = [e["name"] for e in res.effects]
        ok = _right(verdict, named, expected, off)
        rows.append((name, verdict, named, expected, ok, secs))
        print(f"{name:44s} {verdict:12s} {','.join(named) or '-':26s} expected {','.join(expected) or 'none':22s}"
              f" {'right' if ok else 'WRONG':5s} {secs:6.1f} s {'' if secs <= TARGET_SECONDS else '> 60 s'}",
              flush=True)
        for e in res.effects:
            values = ", ".join(f"{k} {v:.4g}" for k, v in e["parameters"].items())
            print(f"{'':44s}   {e['name']}: {values}", flush=True)
    if rows:
        print(f"\n{sum(r[4] for r in rows)} / {len(rows)} right; {sum(r[5] <= TARGET_SECONDS for r in rows)} / "
              f"{len(rows)} within {TARGET_SECONDS:g} s (slowest {max(r[5] for r in rows):.1f} s); "
              f"{args.fit:g} s fit + {args.hold:g} s held out")


if __name__ == "__main__":
    main()
