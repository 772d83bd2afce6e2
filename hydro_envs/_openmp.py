"""The package's OpenMP wait setting: workers spin about 75 us after a parallel region, then sleep.

The vector envs step every copy in a numba parallel kernel (OpenMP layer, libgomp), and torch
runs its operators on its own libgomp. How long an idle libgomp worker spins before it sleeps
is ``GOMP_SPINCOUNT``: libgomp's default is 300 000 spins (milliseconds), and
``OMP_WAIT_POLICY=PASSIVE`` makes it 0. Both ends cost on a small machine:

* workers that spin for milliseconds keep their cores from whatever else runs;
* workers that sleep at once must be woken for every parallel region. On the 2-core
  development VMs that costs 40-90 us per call of an empty parallel kernel, against 2-4 us
  for a worker still spinning (``bench/step_rate.py --profile`` prints it), and it slows
  torch as much.

A short spin keeps most of what a worker that never sleeps gains and gives its core back soon.
Measured on the first development VM (AMD EPYC, a spin about 25 ns), with interleaved runs
(medians of three; ``PASSIVE`` / 3 000 spins / 10 000 spins):

* 1024-copy vector envs, M steps/s: force actuator 1.24 / 1.24 / 1.30, load sensing
  1.18 / 1.37 / 1.53, rodless 1.50 / 1.61 / 1.82, servo 2.07 / 2.66 / 2.37, shaking table
  0.85 / 0.87 / 0.82;
* two such envs in two processes at once (more threads than cores), M steps/s summed:
  2.39-2.64 / 2.30-2.44 / 1.54-1.62. Longer spins keep a worker runnable through the gaps
  between steps, and it then competes for a core with the other process;
* ``python -m agents.train --algo sac --timesteps 2000 --torch-threads 2`` (servo), wall time
  of the whole command: 14.2-15.1 s / 9.0-11.0 s / 9.2-10.7 s.

A spin is one ``pause`` instruction, whose latency differs between CPUs (about 9-10 ns on the
Intel Xeon of a later VM, where 3 000 spins lasted 30 us and a worker slept
through the Python part of every env step). So the count is set for a time,
:data:`SPIN_TIME_US`: the first vector env made sets ``GOMP_SPINCOUNT`` to the count that spins
that long on this CPU (:func:`set_spin_time`, which times ``pause``; :data:`SPIN_COUNT` where
``pause`` cannot be timed), if numba's OpenMP pool has not started yet (libgomp reads the
variable once, when it is loaded). Importing the package sets nothing. A program that loads
torch (which loads libgomp) before its first vector env calls
:func:`hydro_envs.apply_openmp_spin` first, as ``agents.train`` does. A user's own
``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` is left as it is.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping

__all__ = ["SPIN_COUNT", "SPIN_TIME_US", "user_chose", "set_spin_time", "spin_count_for"]

#: spins of an idle libgomp worker before it sleeps where a spin cannot be timed (a CPU other
#: than x86-64, or no ``pause`` intrinsic): 75 us at 25 ns per spin
SPIN_COUNT = "3000"
#: how long an idle libgomp worker spins before it sleeps [us]
SPIN_TIME_US = 75.0

_done = False


def user_chose(environ: Mapping[str, str] = os.environ) -> bool:
    """Whether the OpenMP wait behaviour is set already (``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT``)."""
    return "OMP_WAIT_POLICY" in environ or "GOMP_SPINCOUNT" in environ


def spin_count_for(pause_ns: float, spin_time_us: float = SPIN_TIME_US) -> int:
    """Spins that last ``spin_time_us`` at ``pause_ns`` per spin (at least 1)."""
    if not pause_ns > 0.0:
        raise ValueError(f"pause_ns must be > 0, got {pause_ns}")
    return max(1, round(spin_time_us * 1e3 / pause_ns))


def set_spin_time() -> int | None:
    """Set ``GOMP_SPINCOUNT`` to the count that spins :data:`SPIN_TIME_US` on this CPU, once per
    process, while numba's OpenMP pool has not started and unless the user chose
    (:func:`user_chose`). Returns the count set, or None (a user's setting, a pool already
    running, or a later call). Where ``pause`` cannot be timed the count is :data:`SPIN_COUNT`
    (a ``RuntimeWarning`` says why if timing failed)."""
    global _done
    if _done:
        return None
    _done = True  # once per process
    if user_chose():
        return None
    import numba.np.ufunc.parallel as numba_parallel

    if getattr(numba_parallel, "_is_initialized", True):  # started (or a numba that does not say)
        return None
    try:
        from hydro_envs._numba_cache import ensure_fresh_cache
        from hydro_envs._spin import pause_ns

        ensure_fresh_cache()  # the pause loop is a cached kernel too
        ns = pause_ns()
    except Exception as exc:  # a numba or LLVM without the intrinsic
        warnings.warn(f"hydro_envs: could not time the CPU's pause instruction ({exc!r}); "
                      f"GOMP_SPINCOUNT set to {SPIN_COUNT}", RuntimeWarning, stacklevel=2)
        ns = None
    count = int(SPIN_COUNT) if ns is None else spin_count_for(ns)
    os.environ["GOMP_SPINCOUNT"] = str(count)
    return count
