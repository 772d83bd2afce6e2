"""How long one spin of an idle libgomp worker lasts on this CPU, measured.

libgomp's idle worker polls its work flag and executes the CPU's ``pause`` between polls
(``cpu_relax`` in ``libgomp/config/linux/wait.h``), ``GOMP_SPINCOUNT`` times before it sleeps,
so one spin lasts about one ``pause``. Its latency differs 2-3x between CPUs (about
9-10 ns on an Intel Xeon with AVX-512, 25 ns on the EPYC the package was first timed on), and a
fixed count is a different time on each. :func:`pause_ns` times a compiled loop of ``pause``
instructions (x86-64 only); :func:`hydro_envs._openmp.set_spin_time` turns it into a count for
a spin time. Imports numba: loaded only when a vector env is first made.
"""

from __future__ import annotations

import platform
import time

import numba

from hydro_envs.intrinsics import cpu_pause

__all__ = ["pause_ns"]

X86_64 = platform.machine().lower() in ("x86_64", "amd64")


@numba.njit(cache=True)
def _pause_loop(n):
    for _ in range(n):
        cpu_pause()


def pause_ns(pauses: int = 20_000, repeats: int = 5) -> float | None:
    """Latency [ns] of one ``pause`` instruction (the fastest of ``repeats`` loops of ``pauses``:
    a loop the VM or the OS interrupted only reads longer), or None on a CPU other than x86-64."""
    if not X86_64:
        return None
    _pause_loop(10)  # compile or load from the cache
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        _pause_loop(pauses)
        best = min(best, (time.perf_counter_ns() - t0) / pauses)
    return best
