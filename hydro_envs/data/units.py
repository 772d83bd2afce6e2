"""Units of measured columns and their conversion to the SI unit a plant registers.

A unit is converted once, on loading, by ``si = scale * value + offset``. Pressures may be
marked gauge (``bar(g)``, ``barg``, ``kPa(g)``...) or absolute (``bar(a)``, ``bara``); a gauge
value going into an absolute channel gets the ambient pressure :data:`AMBIENT_PRESSURE`
added, an absolute value going into a gauge channel (one whose name or meaning says
"gauge") gets it subtracted. An unmarked pressure unit is taken as it comes (absolute for an
absolute channel, gauge for a gauge channel).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = ["AMBIENT_PRESSURE", "UnitError", "Conversion", "parse_unit", "conversion", "known_units"]

#: standard atmosphere [Pa] (ISO 2533), added to gauge pressures going into absolute channels
AMBIENT_PRESSURE = 101325.0

# unit -> (SI unit, scale to SI). Exact definitions: inch-pound psi = 6894.757293168 Pa (NIST SP 811).
_TABLE: dict[str, tuple[str, float]] = {
    "s": ("s", 1.0), "ms": ("s", 1e-3), "us": ("s", 1e-6), "µs": ("s", 1e-6), "min": ("s", 60.0),
    "m": ("m", 1.0), "cm": ("m", 1e-2), "mm": ("m", 1e-3), "um": ("m", 1e-6), "µm": ("m", 1e-6),
    "m/s": ("m/s", 1.0), "cm/s": ("m/s", 1e-2), "mm/s": ("m/s", 1e-3),
    "m/s^2": ("m/s^2", 1.0), "mm/s^2": ("m/s^2", 1e-3), "g0": ("m/s^2", 9.80665),
    "m^2": ("m^2", 1.0), "cm^2": ("m^2", 1e-4), "mm^2": ("m^2", 1e-6),
    "N": ("N", 1.0), "kN": ("N", 1e3), "mN": ("N", 1e-3),
    "Pa": ("Pa", 1.0), "kPa": ("Pa", 1e3), "MPa": ("Pa", 1e6), "bar": ("Pa", 1e5),
    "mbar": ("Pa", 1e2), "psi": ("Pa", 6894.757293168),
    "V": ("V", 1.0), "mV": ("V", 1e-3),
    "A": ("A", 1.0), "mA": ("A", 1e-3),
    "rad": ("rad", 1.0), "deg": ("rad", math.pi / 180.0),
    "rad/s": ("rad/s", 1.0), "deg/s": ("rad/s", math.pi / 180.0), "rpm": ("rad/s", math.pi / 30.0),
    "1": ("1", 1.0), "": ("1", 1.0),
}

_GAUGE_RE = re.compile(r"^(.*?)\s*(?:\((g|a|gauge|abs)\)|(g|a))$")


class UnitError(ValueError):
    """A unit that is unknown or does not convert to the expected SI unit."""


@dataclass(frozen=True)
class Conversion:
    """``si = scale * value + offset``; ``note`` says what was done (empty for identity)."""

    unit: str
    si_unit: str
    scale: float
    offset: float
    note: str

    @property
    def identity(self) -> bool:
        return self.scale == 1.0 and self.offset == 0.0

    def apply(self, values):
        """Convert an array (or float) to SI; the identity returns ``values`` unchanged."""
        if self.identity:
            return values
        if self.offset == 0.0:
            return values * self.scale
        return values * self.scale + self.offset


def known_units() -> tuple[str, ...]:
    """All unit spellings understood (gauge/absolute marks aside)."""
    return tuple(u for u in _TABLE if u)


def parse_unit(unit: str) -> tuple[str, str | None]:
    """Split a unit into its base and a pressure reference: ``"bar(g)"`` -> ``("bar", "gauge")``.

    The reference is ``"gauge"``, ``"absolute"`` or ``None`` (not marked). Only pressure units
    carry a mark; ``"g0"`` (standard gravity) is not ``g`` + gauge.
    """
    u = unit.strip()
    if u in _TABLE:
        return u, None
    m = _GAUGE_RE.match(u)
    if m is not None and m.group(1) in _TABLE and _TABLE[m.group(1)][0] == "Pa":
        mark = m.group(2) or m.group(3)
        return m.group(1), ("gauge" if mark in ("g", "gauge") else "absolute")
    return u, None


def conversion(
    unit: str, si_unit: str, *, column: str, gauge_channel: bool = False, gauge: bool | None = None
) -> Conversion:
    """How to convert values of ``column`` given in ``unit`` to the channel's ``si_unit``.

    ``gauge_channel`` says the channel holds gauge pressure; ``gauge`` (True/False) overrides
    the mark in the unit. Raises :class:`UnitError` naming the column, the unit and the
    expected unit when the unit is unknown or of another dimension.
    """
    base, ref = parse_unit(unit)
    if gauge is not None:
        ref = "gauge" if gauge else "absolute"
    if base not in _TABLE:
        raise UnitError(
            f"column {column!r}: unknown unit [{unit}]; expected [{si_unit}] or a unit convertible to it "
            f"(known: {', '.join(u for u in known_units() if _TABLE[u][0] == si_unit) or si_unit})"
        )
    to, scale = _TABLE[base]
    if to != si_unit:
        raise UnitError(
            f"column {column!r}: unit [{unit}] does not convert to [{si_unit}] (it is a unit of [{to}]); "
            f"the channel expects [{si_unit}]"
        )
    offset = 0.0
    notes = []
    if scale != 1.0:
        notes.append(f"converted from [{unit}] to [{si_unit}] (x {scale:g})")
    if to == "Pa" and ref is not None:
        if ref == "gauge" and not gauge_channel:
            offset = AMBIENT_PRESSURE
            notes.append(f"gauge pressure made absolute: + {AMBIENT_PRESSURE:g} Pa ambient")
        elif ref == "absolute" and gauge_channel:
            offset = -AMBIENT_PRESSURE
            notes.append(f"absolute pressure made gauge: - {AMBIENT_PRESSURE:g} Pa ambient")
    return Conversion(unit, si_unit, scale, offset, "; ".join(notes))
