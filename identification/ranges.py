"""From a fit to a randomisation spec and a plant preset.

:func:`ranges_from_fit` turns parameter estimates with their covariance into the exact YAML
schema of a plant's ``randomization.yaml`` (:mod:`hydro_envs.randomization`): one entry per
fitted parameter, ``distribution: uniform``, ``mode: absolute``, ``range: [est - k SE,
est + k SE]`` (``SE = sqrt(diag(cov))``, default ``k = 2``: the marginal ~95 % confidence
interval), clipped to the parameter's allowed interval, the unit of the parameter and a
``source`` naming the data file and the fit.

*Nominal outside the confidence region (decision).* The loader requires each entry's nominal
inside its range. Every emitted entry declares the estimate as its own ``nominal`` (the
schema's key for a spec centred on something other than the plant's default), so a fitted
region that excludes the seed's default still loads unchanged, and the ``source`` records the
default it departs from. ``on_nominal_outside="widen"`` instead extends the range to include
the default (and says so in the ``source``); ``"raise"`` raises :class:`RangesError` naming the
parameter. A fit whose ranges give invalid corners
(e.g. ``F_s`` and ``F_c`` overlapping, so a corner has ``F_s < F_c``) raises too (the spec
loader's corner check, message naming the entry).

*Any plant, any method.* :func:`spec_from_result` takes the result mapping of a ``hydro
identify`` method (``parameters``, ``std_errors``, ``units``) and a target plant of the
registry (:mod:`hydro_envs.registry`; the plant of an env, or a cylinder plant named for the
friction of a rig without an env such as ``slider`` or ``seal_friction``), maps the result's
names to the plant's parameter fields (:data:`METHOD_FIELDS`: the friction fit's ``F_c`` ...
names, the slider's friction fields, the grey-box fit's own field names; a user mapping adds
or replaces entries), refuses a unit that differs from the field's, and builds the spec with
:func:`ranges_from_fit`. Methods whose parameters are not physical parameters of a plant (ARX
coefficients; a mass-spring-damper whose input is a valve command) give a spec only through
an explicit mapping.

Plant presets (``configs/plants/<plant>/presets/<name>.yaml``)::

    plant: servo_cylinder
    name: nominal
    source: "..."
    parameters:
      mass: {value: 12.3, unit: kg, source: "002 Table 1: m"}

:func:`nominal_preset` writes every field of a parameter class with its default and source;
:func:`load_preset` returns the parameter set (unknown names, unit mismatches and invalid
values raise).
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

__all__ = [
    "RangesError",
    "FRICTION_FIELDS",
    "ranges_from_fit",
    "write_ranges",
    "METHOD_FIELDS",
    "spec_from_result",
    "write_spec_from_result",
    "nominal_preset",
    "preset_mapping",
    "write_preset",
    "load_preset",
]

#: reported friction-fit names -> ServoCylinderParams / RodlessCylinderParams fields
FRICTION_FIELDS = {
    "F_c": "coulomb_friction",
    "F_s": "static_friction",
    "v_s": "stribeck_velocity",
    "F_v": "viscous_friction",
}


class RangesError(ValueError):
    """A fit cannot be turned into a randomisation spec (the message names the parameter)."""


def _field_meta(params_cls: type) -> dict[str, Mapping[str, Any]]:
    return {f.name: f.metadata for f in dataclasses.fields(params_cls)}


def ranges_from_fit(
    estimates: Mapping[str, float],
    covariance: Any,
    params_cls: type,
    *,
    names: Sequence[str] | None = None,
    field_map: Mapping[str, str] | None = None,
    k: float = 2.0,
    data_file: str = "",
    fit_description: str = "",
    on_nominal_outside: str = "declare",
) -> dict[str, Any]:
    """Randomisation mapping (plant, parameters) from a fit.

    ``estimates``: name -> value (fit names, mapped to fields by ``field_map``, default
    :data:`FRICTION_FIELDS` plus identity); ``covariance``: matrix in the order of ``names``
    (default: the order of ``estimates``) or a mapping name -> standard error. Estimates
    without a matching field are skipped. See the module docstring for the policy.
    """
    if not (math.isfinite(k) and k > 0):
        raise RangesError(f"k must be > 0, got {k}")
    if on_nominal_outside not in ("declare", "widen", "raise"):
        raise RangesError(f"on_nominal_outside must be 'declare', 'widen' or 'raise', got {on_nominal_outside!r}")
    names = list(estimates) if names is None else list(names)
    if isinstance(covariance, Mapping):
        se = {n: float(covariance[n]) for n in names}
    else:
        cov = np.atleast_2d(np.asarray(covariance, dtype=float))
        if cov.shape != (len(names), len(names)):
            raise RangesError(f"covariance has shape {cov.shape}, expected {(len(names), len(names))} for {names}")
        se = {n: float(math.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(names)}
    fmap = dict(FRICTION_FIELDS if field_map is None else field_map)
    meta = _field_meta(params_cls)
    defaults = params_cls()
    out: dict[str, Any] = {}
    for n in names:
        field = fmap.get(n, n)
        if field not in meta:
            continue
        est, s = float(estimates[n]), se[n]
        if not (math.isfinite(est) and math.isfinite(s)):
            raise RangesError(f"{n} ({field}): estimate {est} or standard error {s} is not finite")
        lo_a, hi_a = meta[field]["allowed"]
        unit = meta[field]["unit"]
        lo, hi = max(est - k * s, lo_a), min(est + k * s, hi_a)
        if meta[field].get("open_low") and lo <= lo_a:
            lo = lo_a + 1e-9 * max(abs(est), 1e-30)
        src = (f"fit: {fit_description or 'parameter estimate'} of {data_file or '<data>'}: "
               f"{est:.6g} +- {k:g} x SE {s:.3g} {unit}, clipped to the allowed [{lo_a:g}, {hi_a:g}]")
        nominal = float(getattr(defaults, field))
        if not (lo <= nominal <= hi) and on_nominal_outside == "declare":
            src += f"; the plant's default {nominal:.6g} {unit} lies outside this range"
        elif not (lo <= nominal <= hi):
            if on_nominal_outside == "raise":
                raise RangesError(
                    f"{field} ({n}): the fit's confidence region [{lo:.6g}, {hi:.6g}] {unit} "
                    f"(estimate {est:.6g} +- {k:g} SE) excludes the nominal {nominal:.6g} {unit}; "
                    "the randomisation loader needs the nominal inside the range (use "
                    "on_nominal_outside='widen' or change the nominal)"
                )
            lo, hi = min(lo, nominal), max(hi, nominal)
            src += f"; widened to include the nominal {nominal:.6g} {unit} (outside the confidence region)"
        if not lo < hi:
            raise RangesError(f"{field} ({n}): empty range [{lo}, {hi}] (zero standard error?)")
        out[field] = {"distribution": "uniform", "mode": "absolute", "range": [float(lo), float(hi)],
                      "unit": unit, "source": src}
        if on_nominal_outside == "declare":
            out[field]["nominal"] = min(max(est, float(lo)), float(hi))
    if not out:
        raise RangesError(f"no estimate of {list(estimates)} matches a field of {params_cls.__name__}")
    return {"plant": params_cls.plant, "parameters": out}


def _dump(path: str | os.PathLike[str], data: Mapping[str, Any], header: str) -> Path:
    from hydro_envs.outputs import atomic_write

    text = yaml.safe_dump(dict(data), sort_keys=False, width=1000)
    return atomic_write(Path(path), "".join(f"# {ln}\n" for ln in header.splitlines()) + text)


def write_ranges(path: str | os.PathLike[str], mapping: Mapping[str, Any], params_cls: type) -> Path:
    """Write a :func:`ranges_from_fit` mapping and check it loads (and its corners are valid)."""
    from hydro_envs.randomization import RandomizationSpec

    RandomizationSpec.from_mapping(mapping, params_cls, source_file=str(path)).check_corners()
    return _dump(path, mapping, "Randomisation spec emitted by identification.ranges from a fit "
                 "(ranges = estimate +- k standard errors).")


# ----------------------------------------------------------------------------- any plant
#: identify method -> result name -> parameter field ("*": every result name is a field name;
#: None: the method's parameters are not plant parameters, a spec needs an explicit mapping)
METHOD_FIELDS: dict[str, Mapping[str, str] | str | None] = {
    "friction": FRICTION_FIELDS,
    "slider": {f: f for f in ("coulomb_friction", "static_friction", "stribeck_velocity", "viscous_friction")},
    "greybox": "*",
    "arx": None,
    "frf": None,
}


def _params_cls_of(plant: str) -> type:
    from hydro_envs import registry

    spec = registry.get(plant)
    if not spec.params_class:
        with_env = [s.name for s in registry.specs() if s.envs]
        raise RangesError(f"plant {plant!r} has no parameter class (measured channels only); name the "
                          f"plant whose parameters the fit calibrates, one of {', '.join(with_env)}")
    return spec.params_cls


def spec_from_result(
    result: Mapping[str, Any],
    plant: str,
    *,
    method: str | None = None,
    field_map: Mapping[str, str] | None = None,
    k: float = 2.0,
    data_file: str = "",
    fit_description: str = "",
    on_nominal_outside: str = "declare",
) -> tuple[dict[str, Any], type]:
    """Randomisation mapping of ``plant`` from an identify result, and the plant's parameter class.

    ``method`` (default ``result["method"]``) picks the name map of :data:`METHOD_FIELDS`;
    ``field_map`` (result name -> field) adds to it or replaces it. Raises :class:`RangesError`
    naming the method, the plant and its fields when nothing maps, and naming the parameter
    when a unit differs from the field's.
    """
    method = method or str(result.get("method", ""))
    cls = _params_cls_of(plant)
    meta = _field_meta(cls)
    params = dict(result.get("parameters") or {})
    se = dict(result.get("std_errors") or {})
    units = dict(result.get("units") or {})
    base = METHOD_FIELDS.get(method)
    fmap: dict[str, str] = {}
    if base == "*":
        fmap = {n: n for n in params}
    elif isinstance(base, Mapping):
        fmap = {n: f for n, f in base.items() if n in params}
    for n, f in (field_map or {}).items():
        if n not in params:
            raise RangesError(f"mapping {n}={f}: the {method} result has no parameter {n!r}; it has {sorted(params)}")
        if f not in meta:
            raise RangesError(f"mapping {n}={f}: {cls.__name__} ({plant}) has no field {f!r}")
        fmap[n] = f
    if not fmap:
        why = ("its parameters are not parameters of a plant" if base is None and method in METHOD_FIELDS
               else f"none of its parameters {sorted(params)} is a field of {cls.__name__}")
        raise RangesError(f"{method or 'this'} result gives no randomisation spec for plant {plant!r}: {why}; "
                          "map a result name to a field explicitly (NAME=FIELD)")
    names = [n for n in fmap if fmap[n] in meta and params.get(n) is not None and se.get(n) is not None]
    if not names:
        raise RangesError(f"{method} result: no parameter of {sorted(fmap)} maps to a field of {cls.__name__} "
                          f"({plant}) with a standard error")
    for n in names:
        want = meta[fmap[n]]["unit"]
        if n in units and str(units[n]) != want:
            raise RangesError(f"{n}: the fit's unit {units[n]!r} differs from {fmap[n]!r}'s {want!r} in "
                              f"{cls.__name__}; the estimate is not that parameter")
    spec = ranges_from_fit({n: float(params[n]) for n in names}, {n: float(se[n]) for n in names}, cls,
                           names=names, field_map=fmap, k=k, data_file=data_file,
                           fit_description=fit_description, on_nominal_outside=on_nominal_outside)
    return spec, cls


def write_spec_from_result(path: str | os.PathLike[str], result: Mapping[str, Any], plant: str,
                           **kwargs: Any) -> Path:
    """:func:`spec_from_result`, checked and written to ``path`` (see :func:`write_ranges`)."""
    spec, cls = spec_from_result(result, plant, **kwargs)
    return write_ranges(path, spec, cls)


# ----------------------------------------------------------------------------- presets
def preset_mapping(params: Any, name: str, source: str,
                   sources: Mapping[str, str] | None = None) -> dict[str, Any]:
    """Preset mapping of a parameter set; ``sources`` overrides the per-field sources."""
    meta = _field_meta(type(params))
    sources = dict(sources or {})
    pars = {}
    for f, m in meta.items():
        pars[f] = {"value": float(getattr(params, f)), "unit": m["unit"],
                   "source": sources.get(f, m.get("source", ""))}
    return {"plant": type(params).plant, "name": name, "source": source, "parameters": pars}


def nominal_preset(params_cls: type) -> dict[str, Any]:
    return preset_mapping(params_cls(), "nominal", f"{params_cls.__name__} defaults (each field's source)")


def write_preset(path: str | os.PathLike[str], mapping: Mapping[str, Any], header: str = "") -> Path:
    return _dump(path, mapping, header or f"Plant preset {mapping.get('name', '')} of {mapping.get('plant', '')}.")


def load_preset(path: str | os.PathLike[str], params_cls: type, require: Sequence[str] = ()) -> Any:
    """Parameter set of a preset file (fields not listed keep their defaults), read with
    :func:`hydro_envs.yamlio.load_yaml` (duplicate keys and alias bombs refused); every entry is
    ``{value: number, unit: the field's unit, source: text}``. A field in ``require`` (the rig's
    geometry, say) must be listed."""
    from hydro_envs.yamlio import YamlError, load_yaml, number, short

    try:
        data = load_yaml(path, what="preset")
    except YamlError as exc:
        raise RangesError(str(exc)) from None
    where = f"preset {path}"
    if not isinstance(data, Mapping) or data.get("plant") != params_cls.plant:
        got = data.get("plant") if isinstance(data, Mapping) else data
        raise RangesError(f"{where}: plant = {short(got)}; allowed {params_cls.plant!r}")
    unknown = sorted(set(map(str, data)) - {"plant", "name", "source", "parameters", "note"})
    if unknown:
        raise RangesError(f"{where}: unknown key(s) {unknown}; allowed name, note, parameters, plant, source")
    meta = _field_meta(params_cls)
    values = {}
    pars = data.get("parameters") or {}
    if not isinstance(pars, Mapping):
        raise RangesError(f"{where}: parameters = {short(pars)}; allowed a mapping of field -> {{value, unit, source}}")
    for f, entry in pars.items():
        if f not in meta:
            raise RangesError(f"{where}: unknown parameter {f!r} of {params_cls.__name__}")
        if not isinstance(entry, Mapping) or "value" not in entry:
            raise RangesError(f"{where}: parameters.{f} = {short(entry)}; allowed {{value: V, unit: U, source: S}}")
        if entry.get("unit") != meta[f]["unit"]:
            raise RangesError(f"{where}: {f}: unit {short(entry.get('unit'))}, expected {meta[f]['unit']!r}")
        if not isinstance(entry.get("source"), str) or not entry["source"].strip():
            raise RangesError(f"{where}: {f}: empty source")
        try:
            values[f] = number(entry["value"], f"parameters.{f}.value", where)
        except YamlError as exc:
            raise RangesError(str(exc)) from None
    missing = [f for f in require if f not in values]
    if missing:
        listed = ", ".join(f"{f} [{meta[f]['unit']}]" for f in missing)
        raise RangesError(f"{where}: the rig's geometry is not listed ({listed}); add each under parameters "
                          "as {value, unit, source}")
    return dataclasses.replace(params_cls(), **values)
