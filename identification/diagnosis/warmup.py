"""Compile the diagnosis rollouts of every plant ahead of a first run.

The workflow integrates each plant's general compiled kernel (every effect switched by a
parameter, not by a kernel variant), so one short diagnosis per plant compiles everything a
diagnosis of that plant calls: the synthetic record's generator, the base fit, the candidate
refits, the held-out free runs and the residual maps. Registered as the ``diagnosis`` warm-up
of ``hydro compile`` (:mod:`hydro_envs.warmup`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

__all__ = ["compile_kernels"]

#: seconds of fit and held-out data: the shortest records every plant's data checks accept
FIT_SECONDS = 4.0
HOLD_SECONDS = 3.0


def compile_kernels(plants: Sequence[str] | None = None,
                    say: Callable[[str], None] = lambda msg: None) -> dict[str, float]:
    """Diagnose a short effect-free synthetic record of each plant (default: every diagnosis
    plant) with one round; returns the seconds each took."""
    from identification.diagnosis.plants import PLANTS
    from identification.diagnosis.synthetic import hidden_effect_records
    from identification.diagnosis.workflow import diagnose

    took: dict[str, float] = {}
    for plant in plants if plants is not None else PLANTS:
        t0 = time.perf_counter()
        case = hidden_effect_records(plant, None, 0, duration=FIT_SECONDS, holdout_duration=HOLD_SECONDS)
        diagnose(plant, [case.fit], [case.holdout], base=case.base.params, max_effects=1)
        took[plant] = time.perf_counter() - t0
        say(f"diagnosis of {plant}: {took[plant]:.1f} s")
    return took
