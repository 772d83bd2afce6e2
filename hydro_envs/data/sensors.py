"""Sensor models of virtual records: what a rig's transducers do to the simulated truth.

:class:`SensorModel` adds white Gaussian noise, rounds positions to an encoder increment
(0.03 mm, 002 sec. 3: "a position measurement resolution of 0.03mm per increment") and
low-passes pressures with a causal filter (002 sec. 4: "the pressure signals were filtered").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

__all__ = ["SensorModel"]


@dataclass(frozen=True)
class SensorModel:
    """Measurement model applied to the simulated truth before writing the data file.

    ``position_noise_std`` [m] and ``pressure_noise_std`` [Pa] white Gaussian noise (per
    sample), ``position_quantization`` [m] encoder increment (rounding), ``pressure_filter_hz``
    cut-off of a causal 2nd-order Butterworth low-pass on the pressures (None: unfiltered).
    """

    position_noise_std: float = 0.0
    position_quantization: float = 0.0
    pressure_noise_std: float = 0.0
    pressure_filter_hz: float | None = None

    def __post_init__(self) -> None:
        for name in ("position_noise_std", "position_quantization", "pressure_noise_std"):
            val = getattr(self, name)
            if not (math.isfinite(val) and val >= 0.0):
                raise ValueError(f"SensorModel.{name} must be finite and >= 0, got {val}")
        if self.pressure_filter_hz is not None and not (
            math.isfinite(self.pressure_filter_hz) and self.pressure_filter_hz > 0
        ):
            raise ValueError(
                f"SensorModel.pressure_filter_hz must be > 0 Hz or None, got {self.pressure_filter_hz}"
            )

    @classmethod
    def ideal(cls) -> "SensorModel":
        return cls()

    @classmethod
    def realistic(cls) -> "SensorModel":
        """0.03 mm encoder (002 sec. 3), 20 kPa pressure noise (assumed: 0.1 % of a 20 MPa
        transducer), pressures low-passed at 50 Hz (assumed; 002 sec. 4 filters them)."""
        return cls(position_quantization=3e-5, pressure_noise_std=2e4, pressure_filter_hz=50.0)

    def apply(self, dt: float, x: np.ndarray, pressures: Sequence[np.ndarray],
              rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
        x_m = np.array(x, dtype=float)
        if self.position_noise_std > 0:
            x_m = x_m + rng.normal(0.0, self.position_noise_std, x_m.shape)
        if self.position_quantization > 0:
            q = self.position_quantization
            x_m = q * np.floor(x_m / q + 0.5)
        out = []
        for p in pressures:
            p_m = np.array(p, dtype=float)
            if self.pressure_noise_std > 0:
                p_m = p_m + rng.normal(0.0, self.pressure_noise_std, p_m.shape)
            if self.pressure_filter_hz is not None:
                fs = 1.0 / dt
                wn = min(self.pressure_filter_hz / (0.5 * fs), 0.99)
                sos = signal.butter(2, wn, output="sos")
                zi = signal.sosfilt_zi(sos) * p_m[0]
                p_m, _ = signal.sosfilt(sos, p_m, zi=zi)
            out.append(p_m)
        return x_m, out

