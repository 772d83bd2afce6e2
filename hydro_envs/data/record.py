"""The in-memory record (:class:`MeasuredData`) and the error every loader raises."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from hydro_envs.data.channels import TIME_CHANNEL

__all__ = ["MeasuredData", "MeasuredDataError"]


class MeasuredDataError(ValueError):
    """A measured-data file (or data to be written) violates the format.

    Attributes ``path``, ``line`` (CSV physical line or parquet data row, 1-based) and
    ``column`` locate the problem when known.
    """

    def __init__(
        self,
        path: str | os.PathLike[str] | None,
        message: str,
        *,
        line: int | None = None,
        column: str | None = None,
    ) -> None:
        self.path = None if path is None else str(path)
        self.line = line
        self.column = column
        prefix = f"{self.path}: " if self.path is not None else ""
        super().__init__(prefix + message)


@dataclass
class MeasuredData:
    """Time series of one record: time ``t`` and the plant's channels, all in SI units.

    ``units`` maps every column name (including ``"t"``) to its unit; ``metadata`` holds
    the ``# key: value`` lines except ``plant`` (which is the ``plant`` attribute).
    """

    plant: str | None
    t: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)
    #: index ranges ``(start, stop)`` (stop exclusive) of the gap-free parts, set when a
    #: record with gaps was loaded with ``allow_gaps=True``; ``None``: one segment
    segments: list[tuple[int, int]] | None = None
    #: columns whose header gave no unit, read in the registered unit ("x [m]", ...); readers
    #: report them (nothing is assumed silently)
    units_assumed: tuple[str, ...] = ()
    #: what the reader noticed and did not use (a column-map sidecar beside the file); readers
    #: print them
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=np.float64)
        if self.t.ndim != 1:
            raise MeasuredDataError(None, f"t must be 1-D, got shape {self.t.shape}")
        chans: dict[str, np.ndarray] = {}
        for name, values in dict(self.channels).items():
            arr = np.asarray(values, dtype=np.float64)
            if arr.shape != self.t.shape:
                raise MeasuredDataError(
                    None,
                    f"channel {name!r} has shape {arr.shape}, expected {self.t.shape} "
                    "(one value per time sample)",
                    column=name,
                )
            chans[name] = arr
        self.channels = chans
        self.units = dict(self.units)
        self.metadata = {str(k): str(v) for k, v in dict(self.metadata).items()}
        if self.segments is not None:
            self.segments = [(int(a), int(b)) for a, b in self.segments]

    # --- access -------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """Channel names (time excluded), in column order."""
        return tuple(self.channels)

    def __getitem__(self, name: str) -> np.ndarray:
        if name == TIME_CHANNEL.name:
            return self.t
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(
                f"no channel {name!r}; available: t, {', '.join(self.channels)}"
            ) from None

    def __contains__(self, name: object) -> bool:
        return name == TIME_CHANNEL.name or name in self.channels

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def n_samples(self) -> int:
        return len(self)

    @property
    def sample_time(self) -> float:
        """Median time step [s] (NaN with fewer than 2 samples)."""
        if len(self) < 2:
            return float("nan")
        return float(np.median(np.diff(self.t)))

    @property
    def duration(self) -> float:
        """``t[-1] - t[0]`` [s] (0 for fewer than 2 samples)."""
        if len(self) < 2:
            return 0.0
        return float(self.t[-1] - self.t[0])

    def to_array(self, names: Sequence[str] | None = None) -> np.ndarray:
        """Stack columns into an ``(n_samples, len(names))`` float64 array.

        ``names`` defaults to all channels (time excluded); ``"t"`` may be listed.
        """
        if names is None:
            names = self.names
        if isinstance(names, str):
            names = (names,)
        cols = [self[n] for n in names]
        if not cols:
            return np.empty((len(self), 0))
        return np.column_stack(cols)

    # --- segments and resampling --------------------------------------------------------
    def segment(self, k: int) -> "MeasuredData":
        """Segment ``k`` (see :attr:`segments`) as a record of its own."""
        segs = self.segments or [(0, len(self))]
        if not -len(segs) <= k < len(segs):
            raise IndexError(f"segment {k} out of range; the record has {len(segs)} segment(s)")
        a, b = segs[k]
        return MeasuredData(self.plant, self.t[a:b], {n: v[a:b] for n, v in self.channels.items()},
                            self.units, self.metadata)

    def resample_uniform(self, sample_time: float | None = None) -> "MeasuredData":
        """The record linearly interpolated onto the uniform grid ``t0 + k * sample_time``.

        ``sample_time`` defaults to the median step. Meant for removing a logger's clock jitter
        (see :mod:`hydro_envs.data.checks`); a record with several segments is refused (resample
        each :meth:`segment`), so a gap is never interpolated.
        """
        if self.segments is not None and len(self.segments) > 1:
            raise MeasuredDataError(None, f"the record has {len(self.segments)} segments (gaps); resample each "
                                    "segment(k) on its own -- gaps are never interpolated", column="t")
        h = self.sample_time if sample_time is None else float(sample_time)
        if not (h > 0):
            raise MeasuredDataError(None, f"sample_time must be > 0, got {h!r}", column="t")
        n = int(np.floor((self.t[-1] - self.t[0]) / h * (1 + 1e-12))) + 1
        grid = self.t[0] + h * np.arange(n)
        chans = {name: np.interp(grid, self.t, v) for name, v in self.channels.items()}
        meta = dict(self.metadata, resampled=f"linear interpolation onto a uniform grid, step {h!r} s")
        return MeasuredData(self.plant, grid, chans, self.units, meta)
