"""A differential cylinder from a parameter file with units, as a data sheet gives its values.

A file (or mapping) names the rig's values with their units, converted to SI once, here::

    plant: differential_cylinder          # optional
    bore: 63 mm
    rod: 36 mm
    stroke: 300 mm
    supply_pressure: 160 bar              # pressure levels are gauge unless marked: 161 bar(a)
    mass: 40 kg
    valve: {rated_flow: 40 L/min, rated_pressure_drop: 70 bar, bandwidth: 60 Hz, damping: 0.7}
    friction: {coulomb: 87 N, static: 130 N, viscous: 540 N s/m, stribeck_velocity: 10 mm/s}

Top-level keys are :class:`~hydro_envs.plants.differential_cylinder.params.DifferentialCylinderParams`
fields; the ``valve`` and ``friction`` sections take the short names of :data:`SECTIONS`. A
value is ``"NUMBER UNIT"`` (units of :mod:`hydro_envs.data.units`, and those of :data:`EXTRA_UNITS`)
or a bare number, taken in the field's SI unit (pressures absolute). Fields the file does not
name keep the example rig's values. Every value is checked against the field's physical bounds:
a wrong unit, a non-number or an impossible value raises
:class:`~hydro_envs.params.ParameterError` naming the file, the field, the value and its unit.
``load_rig(source)`` takes a path, a mapping, or the name of a shipped file (``configs/datasheets/``).
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path
from typing import Any, Mapping

from hydro_envs.params import ParameterError
from hydro_envs.plants.differential_cylinder.params import DifferentialCylinderParams

__all__ = ["SECTIONS", "EXTRA_UNITS", "load_rig", "rig_mapping", "is_rig_source", "shipped_files", "to_si"]

#: section -> {short name: parameter field}
SECTIONS: dict[str, dict[str, str]] = {
    "valve": {"rated_flow": "rated_flow", "rated_pressure_drop": "rated_pressure_drop",
              "bandwidth": "valve_bandwidth", "damping": "valve_damping", "lap": "valve_lap",
              "command_max": "command_max"},
    "friction": {"coulomb": "coulomb_friction", "static": "static_friction", "viscous": "viscous_friction",
                 "stribeck_velocity": "stribeck_velocity", "bristle_stiffness": "bristle_stiffness",
                 "bristle_damping": "bristle_damping"},
}
#: units beyond hydro_envs.data.units' table: unit -> (SI unit, scale)
EXTRA_UNITS: dict[str, tuple[str, float]] = {
    "m^3/s": ("m^3/s", 1.0), "L/min": ("m^3/s", 1e-3 / 60.0), "l/min": ("m^3/s", 1e-3 / 60.0),
    "L/s": ("m^3/s", 1e-3), "cm^3/s": ("m^3/s", 1e-6),
    "m^3": ("m^3", 1.0), "L": ("m^3", 1e-3), "l": ("m^3", 1e-3), "cm^3": ("m^3", 1e-6), "ccm": ("m^3", 1e-6),
    "kg": ("kg", 1.0), "g": ("kg", 1e-3), "t": ("kg", 1e3),
    "Hz": ("Hz", 1.0), "kHz": ("Hz", 1e3), "1/s": ("1/s", 1.0),
    "N s/m": ("N s/m", 1.0), "N/(m/s)": ("N s/m", 1.0), "N s/mm": ("N s/m", 1e3),
    "N/m": ("N/m", 1.0), "N/mm": ("N/m", 1e3), "N/um": ("N/m", 1e6),
    "GPa": ("Pa", 1e9), "%": ("1", 0.01), "s/m": ("s/m", 1.0),
}
#: pressure levels (not differences): a unit without a gauge/absolute mark is gauge there
_PRESSURE_LEVELS = ("supply_pressure", "tank_pressure", "pressure_floor")
_NUMBER_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def _fields() -> dict[str, dataclasses.Field]:
    return {f.name: f for f in dataclasses.fields(DifferentialCylinderParams)}


def _round_si(x: float) -> float:
    """``x`` rounded to 15 significant digits: a unit's binary scale leaves no trace (``63 mm`` is
    ``0.063 m`` exactly, not 0.063000000000000004)."""
    return float(f"{x:.15g}") if math.isfinite(x) else x


def to_si(value: Any, field: str, where: str) -> float:
    """``value`` (a number in the field's SI unit, or ``"NUMBER UNIT"``) in the field's SI unit,
    checked against its allowed range (:class:`ParameterError` naming ``where``, field, value, unit)."""
    from hydro_envs.data.units import UnitError, conversion

    meta = _fields()[field].metadata
    si = meta["unit"]
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ParameterError(f"{where}: {field} = {value!r} must be a number or 'NUMBER UNIT' (in [{si}])")
    if isinstance(value, str):
        m = _NUMBER_UNIT.match(value)
        if m is None:
            raise ParameterError(f"{where}: {field} = {value!r} is not 'NUMBER UNIT' (e.g. '63 mm'; field in [{si}])")
        number, unit = float(m.group(1)), m.group(2) or si
        if unit in EXTRA_UNITS:
            to, scale = EXTRA_UNITS[unit]
            if to != si:
                raise ParameterError(f"{where}: {field} = {value!r}: unit [{unit}] is a unit of [{to}], "
                                     f"the field expects [{si}]")
            out = number * scale
        else:
            gauge = True if (field in _PRESSURE_LEVELS and si == "Pa") else None
            try:
                from hydro_envs.data.units import parse_unit

                if gauge and parse_unit(unit)[1] is not None:
                    gauge = None  # the unit's own mark (bar(a), barg)
                conv = conversion(unit, si, column=field, gauge=gauge)
            except UnitError as exc:
                raise ParameterError(f"{where}: {field} = {value!r}: {exc}") from None
            out = float(conv.apply(number))
    else:
        number, unit, out = float(value), si, float(value)
    out = _round_si(out)
    lo, hi = meta["allowed"]
    bad = (not math.isfinite(out) or out < lo or out > hi or (meta["open_low"] and out == lo)
           or (meta["open_high"] and out == hi))
    if bad:
        left, right = ("(" if meta["open_low"] else "["), (")" if meta["open_high"] else "]")
        raise ParameterError(f"{where}: {field} = {number:g} {unit} ({out:g} {si}) is outside the physically "
                             f"allowed range {left}{lo:g}, {hi:g}{right} {si}")
    return out


def rig_mapping(data: Mapping[str, Any], where: str = "parameter mapping") -> dict[str, float]:
    """The SI field values a parameter mapping gives (sections flattened, units converted)."""
    if not isinstance(data, Mapping):
        raise ParameterError(f"{where}: expected a mapping of parameter -> value, got {type(data).__name__}")
    fields = _fields()
    out: dict[str, float] = {}
    for key, value in data.items():
        if key == "plant":
            if value != DifferentialCylinderParams.plant:
                raise ParameterError(f"{where}: plant = {value!r}; this file is for {DifferentialCylinderParams.plant!r}")
            continue
        if key in SECTIONS:
            if not isinstance(value, Mapping):
                raise ParameterError(f"{where}: section {key!r} must be a mapping, got {value!r}")
            for short, v in value.items():
                if short not in SECTIONS[key]:
                    raise ParameterError(f"{where}: unknown key {key}.{short}; allowed: {', '.join(SECTIONS[key])}")
                name = SECTIONS[key][short]
                out[name] = to_si(v, name, where)
        elif key in fields:
            out[key] = to_si(value, key, where)
        else:
            raise ParameterError(f"{where}: unknown parameter {key!r}; allowed: plant, {', '.join(SECTIONS)}, "
                                 f"{', '.join(fields)}")
    return out


def shipped_files() -> dict[str, Any]:
    """Shipped parameter files (``configs/datasheets/``): stem -> Traversable."""
    from hydro_envs.config_files import config_file

    folder = config_file("datasheets")
    return {p.name.rsplit(".", 1)[0]: p for p in folder.iterdir() if p.name.endswith(".yaml")}


def _resolve(source: str | os.PathLike) -> Any:
    path = Path(source)
    if path.exists():
        return path
    shipped = shipped_files()
    stem = path.name.rsplit(".", 1)[0] if path.name.endswith((".yaml", ".yml")) else path.name
    if stem in shipped:
        return shipped[stem]
    raise ParameterError(f"parameter file {str(source)!r} not found (shipped: {', '.join(sorted(shipped))})")


def is_rig_source(params: Any) -> bool:
    """Whether ``params`` is a parameter file (path) or a mapping with units or sections, i.e.
    something :func:`load_rig` reads rather than a plain mapping of SI field values."""
    if isinstance(params, (str, os.PathLike)):
        return True
    if isinstance(params, Mapping):
        return any(k in SECTIONS or k == "plant" or isinstance(v, str) for k, v in params.items())
    return False


def load_rig(source: Any) -> DifferentialCylinderParams:
    """The parameter set of a parameter file (path or shipped name) or mapping (module docstring)."""
    if isinstance(source, (str, os.PathLike)):
        from hydro_envs.yamlio import YamlError, load_yaml

        path = _resolve(source)
        where = f"parameter file {path}"
        try:
            data = load_yaml(path, what="parameter file")
        except YamlError as exc:
            raise ParameterError(str(exc)) from None
    else:
        data, where = source, "parameter mapping"
    values = rig_mapping(data, where)
    try:
        return DifferentialCylinderParams(**values)
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None
