"""Declarative domain randomisation: which parameters are drawn, from what, and why.

A randomisation file (each plant ships its default as ``configs/plants/<plant>/randomization.yaml``,
:mod:`hydro_envs.config_files`) lists one entry per drawn parameter; every other parameter
keeps its nominal value::

    plant: servo_cylinder
    parameters:
      mass:
        distribution: uniform        # uniform | loguniform
        mode: scale                  # absolute: the draw is the value
                                     # scale: value = nominal * draw
        range: [0.8, 1.5]            # of the draw (absolute value or factor)
        unit: "1"                    # unit of the draw: the parameter's unit, or "1" for scale
        source: "002 Table 1 (m = 12.3 kg); range assumed: +-load variation"

An absolute entry may also give ``nominal: VALUE`` (in the parameter's unit): the value the
spec is centred on when it is not the plant's default -- typically an identified estimate
(``hydro identify ... --emit-ranges``), whose confidence range need not contain the seed's
value. It replaces the default in the containment check below; the draws do not depend on it.

Draws are *never* offsets added to the nominal value (a well-known suite adds draws while its
comments read as absolute ranges). The file is checked when loaded: unknown parameters,
unknown keys, empty or inverted ranges, a unit that differs from the parameter's, a range that
does not contain the nominal value, or a corner of the ranges that gives an invalid parameter
set all raise :class:`RandomizationError` naming the entry.

The nominal model stays apart from the randomised truth: envs draw a truth each episode,
controllers are designed on the nominal set.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from hydro_envs.params import ParameterError, PhysicalParams
from hydro_envs.yamlio import short

__all__ = [
    "RandomizationError",
    "ParameterDistribution",
    "RandomizationSpec",
    "randomization_path",
    "load_randomization",
]

_DISTRIBUTIONS = ("uniform", "loguniform")
_MODES = ("absolute", "scale")
_KEYS = {"distribution", "mode", "range", "unit", "source", "note", "nominal"}
_TOP_KEYS = {"plant", "parameters", "note"}


class RandomizationError(ValueError):
    """A randomisation spec is malformed or would produce invalid parameters."""


def _as_number(value: Any) -> Any:
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def randomization_path(plant: str) -> Any:
    """The default randomisation spec of ``plant``: ``configs/plants/<plant>/randomization.yaml``
    (:mod:`hydro_envs.config_files`), or ``$HYDRO_ENVS_CONFIG_DIR/randomization/<plant>.yaml`` when that
    variable is set."""
    env = os.environ.get("HYDRO_ENVS_CONFIG_DIR")
    if env:
        return Path(env) / "randomization" / f"{plant}.yaml"
    from hydro_envs import registry

    path = registry.get(plant).randomization_file()
    if path is None:
        raise RandomizationError(f"plant {plant!r} ships no randomisation spec")
    return path


@dataclasses.dataclass(frozen=True)
class ParameterDistribution:
    """How one parameter is drawn."""

    name: str
    distribution: str
    mode: str
    low: float
    high: float
    unit: str
    source: str
    #: the value this entry is centred on when it is not the plant's default (absolute mode)
    nominal: float | None = None

    def sample(self, rng: np.random.Generator, nominal: float) -> float:
        if self.distribution == "uniform":
            draw = rng.uniform(self.low, self.high)
        else:  # loguniform
            draw = math.exp(rng.uniform(math.log(self.low), math.log(self.high)))
        return float(draw * nominal if self.mode == "scale" else draw)

    def value_range(self, nominal: float) -> tuple[float, float]:
        if self.mode == "scale":
            a, b = self.low * nominal, self.high * nominal
            return (min(a, b), max(a, b))
        return (self.low, self.high)

    def widened(self, factor: float) -> "ParameterDistribution":
        """The same entry with its range grown by ``factor`` about its centre (log centre
        for loguniform); used for out-of-distribution evaluation."""
        if self.distribution == "loguniform":
            c = 0.5 * (math.log(self.low) + math.log(self.high))
            r = 0.5 * (math.log(self.high) - math.log(self.low)) * factor
            return dataclasses.replace(self, low=math.exp(c - r), high=math.exp(c + r))
        c = 0.5 * (self.low + self.high)
        r = 0.5 * (self.high - self.low) * factor
        return dataclasses.replace(self, low=c - r, high=c + r)


@dataclasses.dataclass(frozen=True)
class RandomizationSpec:
    """An ordered set of parameter distributions for one parameter class."""

    params_cls: type
    entries: tuple[ParameterDistribution, ...]
    source_file: str = "<memory>"

    # ------------------------------------------------------------------ loading
    @classmethod
    def from_mapping(
        cls, data: Mapping[str, Any], params_cls: type, source_file: str = "<memory>"
    ) -> "RandomizationSpec":
        where = f"randomisation spec {source_file}"
        if not isinstance(data, Mapping):
            raise RandomizationError(f"{where}: top level must be a mapping")
        extra_top = set(data) - _TOP_KEYS
        if extra_top:
            raise RandomizationError(
                f"{where}: unknown top-level key(s) {sorted(map(repr, extra_top))}; allowed {sorted(_TOP_KEYS)}"
            )
        plant = data.get("plant")
        if plant != params_cls.plant:
            raise RandomizationError(
                f"{where}: plant = {short(plant)}; allowed {params_cls.plant!r}"
            )
        raw = data.get("parameters")
        if not isinstance(raw, Mapping) or not raw:
            raise RandomizationError(f"{where}: 'parameters' must be a non-empty mapping")
        nominal = params_cls()
        units = {row["name"]: row["unit"] for row in params_cls.describe()}
        entries = []
        for name, entry in raw.items():
            ew = f"{where}: parameters.{name}"
            if name not in units:
                raise RandomizationError(f"{ew}: unknown parameter; known: {sorted(units)}")
            if not isinstance(entry, Mapping):
                raise RandomizationError(f"{ew}: must be a mapping")
            extra = set(entry) - _KEYS
            if extra:
                raise RandomizationError(f"{ew}: unknown key(s) {sorted(extra)}; allowed {sorted(_KEYS)}")
            for key in ("distribution", "mode", "range", "unit", "source"):
                if key not in entry:
                    raise RandomizationError(f"{ew}: missing '{key}'")
            if not isinstance(entry["source"], str) or not entry["source"].strip():
                raise RandomizationError(
                    f"{ew}.source must say where the nominal value and the range come from "
                    f"(a seed table, a data sheet or 'assumed: <reason>'), got {short(entry['source'])}"
                )
            dist, mode = entry["distribution"], entry["mode"]
            if dist not in _DISTRIBUTIONS:
                raise RandomizationError(f"{ew}.distribution = {short(dist)}; allowed {_DISTRIBUTIONS}")
            if mode not in _MODES:
                raise RandomizationError(f"{ew}.mode = {short(mode)}; allowed {_MODES}")
            rng = entry["range"]
            if isinstance(rng, (list, tuple)):
                # YAML 1.1 reads "12.6e6" (no sign in the exponent) as a string: accept it
                rng = [_as_number(r) for r in rng]
            if (
                not isinstance(rng, (list, tuple))
                or len(rng) != 2
                or not all(
                    isinstance(r, (int, float)) and not isinstance(r, bool) and math.isfinite(r)
                    for r in rng
                )
            ):
                raise RandomizationError(f"{ew}.range = {short(rng)}; allowed two finite numbers [low, high]")
            low, high = float(rng[0]), float(rng[1])
            if not low <= high:
                raise RandomizationError(f"{ew}.range [{low}, {high}] is inverted (need low <= high)")
            if dist == "loguniform" and low <= 0:
                raise RandomizationError(f"{ew}.range must be > 0 for loguniform, got [{low}, {high}]")
            want_unit = "1" if mode == "scale" else units[name]
            if str(entry["unit"]) != want_unit:
                raise RandomizationError(
                    f"{ew}.unit = {short(entry['unit'])}, but a {mode} draw of {name} is in {want_unit!r}"
                )
            own = _as_number(entry.get("nominal"))
            if own is not None:
                if mode != "absolute":
                    raise RandomizationError(f"{ew}.nominal is only allowed with mode: absolute (a scale "
                                             "draw multiplies the plant's default)")
                if not (isinstance(own, (int, float)) and not isinstance(own, bool) and math.isfinite(own)):
                    raise RandomizationError(f"{ew}.nominal = {short(own)}; allowed a finite number in {units[name]}")
                own = float(own)
            d = ParameterDistribution(name, dist, mode, low, high, want_unit, str(entry["source"]), own)
            nom = getattr(nominal, name) if own is None else own
            lo_v, hi_v = d.value_range(nom)
            if not lo_v <= nom <= hi_v:
                raise RandomizationError(
                    f"{ew}: {'nominal' if own is None else 'the entry' + chr(39) + 's nominal'} value {nom:g} "
                    f"{units[name]} lies outside the drawn range [{lo_v:g}, {hi_v:g}]"
                )
            entries.append(d)
        spec = cls(params_cls, tuple(entries), source_file)
        spec.check_corners()
        return spec

    @classmethod
    def from_yaml(cls, path: Any, params_cls: type) -> "RandomizationSpec":
        """Load a YAML file (a path or an importlib.resources Traversable)."""
        from hydro_envs.yamlio import YamlError, load_yaml

        if isinstance(path, (str, os.PathLike)):
            path = Path(path)
        try:
            data = load_yaml(path, what="randomisation spec")
        except YamlError as exc:
            raise RandomizationError(str(exc)) from None
        return cls.from_mapping(data, params_cls, str(path))

    # ------------------------------------------------------------------ use
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(e.name for e in self.entries)

    def sample(self, rng: np.random.Generator, base: PhysicalParams | None = None) -> PhysicalParams:
        """Draw one parameter set; parameters not in the spec keep ``base``'s values."""
        base = base if base is not None else self.params_cls()
        values = {e.name: e.sample(rng, getattr(base, e.name)) for e in self.entries}
        return dataclasses.replace(base, **values)

    def corner(self, high: Iterable[bool] | bool, base: PhysicalParams | None = None) -> PhysicalParams:
        """The parameter set at one corner of the ranges (``high[i]`` picks each end)."""
        base = base if base is not None else self.params_cls()
        flags = [high] * len(self.entries) if isinstance(high, bool) else list(high)
        values = {}
        for e, hi in zip(self.entries, flags):
            lo_v, hi_v = e.value_range(getattr(base, e.name))
            values[e.name] = hi_v if hi else lo_v
        return dataclasses.replace(base, **values)

    def check_corners(self, n_random: int = 64, base: PhysicalParams | None = None) -> None:
        """Both all-low/all-high corners and random corners must be valid parameter sets
        (around ``base``, default the nominal set)."""
        rng = np.random.default_rng(0)
        corners = [[False] * len(self.entries), [True] * len(self.entries)]
        corners += [list(rng.integers(0, 2, len(self.entries)).astype(bool)) for _ in range(n_random)]
        for flags in corners:
            try:
                self.corner(flags, base)
            except ParameterError as exc:
                raise RandomizationError(
                    f"randomisation spec {self.source_file}: a corner of the ranges is invalid: {exc}"
                ) from exc

    def widened(self, factor: float) -> "RandomizationSpec":
        """Ranges grown by ``factor`` (benchmark 'out' draws). Invalid draws are the caller's
        to reject; the widened spec is not corner-checked."""
        return dataclasses.replace(self, entries=tuple(e.widened(factor) for e in self.entries))

    def table(self) -> list[dict[str, Any]]:
        nominal = self.params_cls()
        rows = []
        for e in self.entries:
            lo_v, hi_v = e.value_range(getattr(nominal, e.name))
            rows.append(
                {
                    "name": e.name,
                    "distribution": e.distribution,
                    "mode": e.mode,
                    "range": (e.low, e.high),
                    "value_range": (lo_v, hi_v),
                    "nominal": getattr(nominal, e.name),
                    "source": e.source,
                }
            )
        return rows


def load_randomization(plant: str, params_cls: type | None = None, path: Any = None) -> RandomizationSpec:
    """Load the plant's default randomisation spec (:func:`randomization_path`) or ``path``.

    ``params_cls`` defaults to the plant's parameter class from the registry."""
    if params_cls is None:
        from hydro_envs import registry

        params_cls = registry.get(plant).params_cls
    return RandomizationSpec.from_yaml(path if path is not None else randomization_path(plant), params_cls)
