"""Validated physical parameter sets.

Every plant describes its parameters as a frozen dataclass whose fields are declared with
:func:`physical`: a default value, its SI unit, the physically allowed interval and the
source of the default (a seed table, a data sheet, or ``"assumed: <reason>"``). Creating an
instance checks every field and raises :class:`ParameterError` naming the field, the value
and the allowed range, so a typo in a config never reaches a numba kernel.

Kernels take parameters as a flat ``float64`` array; :meth:`PhysicalParams.to_array` packs
the fields in declaration order, which is also the column order of a batch ``(n, n_params)``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

__all__ = ["ParameterError", "PhysicalParams", "geometry_text", "missing_geometry_error", "physical"]


class ParameterError(ValueError):
    """A parameter value is missing, unknown, non-finite or outside its allowed range."""


def physical(
    default: float,
    unit: str,
    allowed: tuple[float, float],
    source: str,
    *,
    open_low: bool = False,
    open_high: bool = False,
    doc: str = "",
) -> Any:
    """Declare a dataclass field holding a physical quantity.

    ``allowed`` is the closed interval of physically meaningful values; ``open_low`` /
    ``open_high`` make an end exclusive (``mass`` > 0, say).
    """
    lo, hi = allowed
    if not (lo <= default <= hi):  # a defect in the declaration itself
        raise ParameterError(f"default {default} outside its own allowed range [{lo}, {hi}]")
    meta = {
        "unit": unit,
        "allowed": (float(lo), float(hi)),
        "open_low": open_low,
        "open_high": open_high,
        "source": source,
        "doc": doc,
    }
    return dataclasses.field(default=float(default), metadata=meta)


def _interval_text(lo: float, hi: float, open_low: bool, open_high: bool, unit: str) -> str:
    left = "(" if open_low else "["
    right = ")" if open_high else "]"
    return f"{left}{lo:g}, {hi:g}{right} {unit}".rstrip()


@dataclasses.dataclass(frozen=True)
class PhysicalParams:
    """Base class: field checks, array packing, and construction from mappings."""

    #: Plant name used by configs, channels and the CLI (set by subclasses).
    plant: ClassVar[str] = ""
    #: Names of the derived kernel columns :meth:`to_array` appends after the fields: terms of a
    #: plant's right-hand side that depend on the parameters only, computed once per set by
    #: :meth:`derived_columns` (none by default).
    derived_names: ClassVar[tuple[str, ...]] = ()
    #: The rig's dimensions: fields a measured record cannot reveal, so identification and
    #: diagnosis never take them from the defaults silently (the seed rig's values) -- a command
    #: fitting a record asks for each (a flag, a preset, the file's metadata) or for an explicit
    #: "use the seed rig" flag (see :func:`geometry_text`).
    geometry: ClassVar[tuple[str, ...]] = ()

    def __post_init__(self) -> None:
        for f in self._fields():
            value = getattr(self, f.name)
            try:
                if isinstance(value, (bool, np.bool_)):  # float(True) == 1.0: a typo, not a value
                    raise TypeError
                value = float(value)
            except (TypeError, ValueError):
                raise ParameterError(
                    f"{type(self).__name__}.{f.name} must be a number, got {value!r}"
                ) from None
            object.__setattr__(self, f.name, value)
            meta = f.metadata
            lo, hi = meta["allowed"]
            bad = (
                not math.isfinite(value)
                or value < lo
                or value > hi
                or (meta["open_low"] and value == lo)
                or (meta["open_high"] and value == hi)
            )
            if bad:
                allowed = _interval_text(lo, hi, meta["open_low"], meta["open_high"], meta["unit"])
                raise ParameterError(
                    f"{type(self).__name__}.{f.name} = {value!r} is outside the allowed "
                    f"range {allowed}"
                )
        self._check_relations()

    def _check_relations(self) -> None:
        """Cross-field constraints (e.g. static >= Coulomb friction); override."""

    # ------------------------------------------------------------------ packing
    @classmethod
    def _layout(cls) -> tuple[tuple[dataclasses.Field, ...], tuple[str, ...]]:
        """``dataclasses.fields(cls)`` and their names, computed once per class (every
        construction and every :meth:`to_array` reads them)."""
        cached = cls.__dict__.get("_layout_cache")
        if cached is None:
            fields = dataclasses.fields(cls)
            cached = (fields, tuple(f.name for f in fields))
            setattr(cls, "_layout_cache", cached)
        return cached

    @classmethod
    def _fields(cls) -> tuple[dataclasses.Field, ...]:
        return cls._layout()[0]

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return cls._layout()[1]

    @classmethod
    def index(cls, name: str) -> int:
        return cls.names().index(name)

    def derived_columns(self) -> Sequence[float]:
        """Values of :attr:`derived_names` (override together with it)."""
        return ()

    def to_array(self) -> np.ndarray:
        """The kernel parameter row: the fields in declaration order, then the derived columns.
        A parameter set is immutable, so its derived columns (some need a root find) are computed
        once; every call returns a new array."""
        fields = np.array([getattr(self, n) for n in self.names()], dtype=np.float64)
        if not self.derived_names:
            return fields
        extra = self.__dict__.get("_derived_row")
        if extra is None:
            extra = np.asarray(self.derived_columns(), dtype=np.float64)
            if extra.shape != (len(self.derived_names),):
                raise ParameterError(f"{type(self).__name__}.derived_columns gave {extra.shape[0]} values for "
                                     f"{len(self.derived_names)} derived_names")
            object.__setattr__(self, "_derived_row", extra)
        return np.concatenate([fields, extra])

    @classmethod
    def from_array(cls, values: np.ndarray) -> "PhysicalParams":
        """The parameter set of a kernel row, with or without its derived columns."""
        values = np.asarray(values, dtype=np.float64)
        n, k = len(cls.names()), len(cls.derived_names)
        if values.shape not in ((n,), (n + k,)):
            alt = f" (or {n + k} with derived columns)" if k else ""
            raise ParameterError(f"{cls.__name__}: expected {n}{alt} values, got shape {values.shape}")
        return cls(**{name: float(v) for name, v in zip(cls.names(), values[:n])})

    def as_dict(self) -> dict[str, float]:
        return {n: getattr(self, n) for n in self.names()}

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], base: "PhysicalParams | None" = None):
        """Override fields of ``base`` (default: the nominal set) by name; unknown names raise."""
        unknown = sorted(set(values) - set(cls.names()))
        if unknown:
            raise ParameterError(
                f"{cls.__name__}: unknown parameter(s) {unknown}; known: {list(cls.names())}"
            )
        base = base if base is not None else cls()
        return dataclasses.replace(base, **{k: values[k] for k in values})

    @classmethod
    def describe(cls) -> list[dict[str, Any]]:
        """One row per field: name, default, unit, allowed range, source."""
        rows = []
        for f in dataclasses.fields(cls):
            rows.append(
                {
                    "name": f.name,
                    "default": f.default,
                    "unit": f.metadata["unit"],
                    "allowed": f.metadata["allowed"],
                    "source": f.metadata["source"],
                }
            )
        return rows


def geometry_text(params: PhysicalParams, names: Sequence[str] | None = None) -> str:
    """``name value unit`` of the geometry fields ``names`` (default: all of
    :attr:`PhysicalParams.geometry`) of ``params``, comma-separated, for messages."""
    meta = {f.name: f.metadata for f in dataclasses.fields(params)}
    names = type(params).geometry if names is None else names
    return ", ".join(f"{n} {getattr(params, n):g} {meta[n]['unit']}".rstrip() for n in names)


def missing_geometry_error(params_cls: type[PhysicalParams], given: Sequence[str], where: str,
                           how: str, nominal_flag: str) -> ParameterError | None:
    """The one-line error a command raises when a record is fitted without the rig's dimensions:
    ``None`` when every :attr:`PhysicalParams.geometry` field of ``params_cls`` is in ``given``;
    else an error naming the missing fields with their units, ``how`` to give them, and
    ``nominal_flag``, which takes the defaults (the seed rig's, printed) on purpose."""
    missing = [n for n in params_cls.geometry if n not in set(given)]
    if not missing:
        return None
    meta = {f.name: f.metadata for f in dataclasses.fields(params_cls)}
    names = ", ".join(f"{n} [{meta[n]['unit']}]" for n in missing)
    return ParameterError(
        f"{where}: the rig's geometry is not given ({names}); {how}, or {nominal_flag} to use "
        f"the seed rig's ({geometry_text(params_cls(), missing)})")
