"""The package's OpenMP wait default: workers spin briefly after a parallel region, then sleep.

The vector envs step every copy in a numba parallel kernel (OpenMP layer, libgomp), and torch
runs its operators on its own libgomp. How long an idle libgomp worker spins before it sleeps
is ``GOMP_SPINCOUNT``: libgomp's default is 300 000 spins (milliseconds), and
``OMP_WAIT_POLICY=PASSIVE`` makes it 0. Both ends cost on a small machine:

* workers that spin for milliseconds keep their cores from whatever else runs;
* workers that sleep at once must be woken for every parallel region. On the 2-core
  development VM (KVM) that costs about 50 us per call of an empty parallel kernel, against
  1.5-2 us for a worker still spinning (``bench/step_rate.py --profile`` prints it), and it
  slows torch as much.

``SPIN_COUNT`` spins last about 75 us there. Measured with interleaved runs on that VM
(medians of three; ``PASSIVE`` / 3 000 spins / 10 000 spins):

* 1024-copy vector envs, M steps/s: force actuator 1.24 / 1.24 / 1.30, load sensing
  1.18 / 1.37 / 1.53, rodless 1.50 / 1.61 / 1.82, servo 2.07 / 2.66 / 2.37, shaking table
  0.85 / 0.87 / 0.82;
* two such envs in two processes at once (more threads than cores), M steps/s summed:
  2.39-2.64 / 2.30-2.44 / 1.54-1.62. Longer spins keep a worker runnable through the gaps
  between steps, and it then competes for a core with the other process;
* ``python -m agents.train --algo sac --timesteps 2000 --torch-threads 2`` (servo), wall time
  of the whole command: 14.2-15.1 s / 9.0-11.0 s / 9.2-10.7 s.

So a short spin keeps most of what a worker that never sleeps gains and gives its core back
soon; a user's own ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` is left as it is. libgomp reads
the variables once, when it is loaded (by the first parallel kernel or by torch), so
:func:`set_wait_default` runs when the package is imported, before either.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping

__all__ = ["SPIN_COUNT", "set_wait_default"]

#: spins of an idle libgomp worker before it sleeps (about 75 us on the development VM)
SPIN_COUNT = "3000"


def set_wait_default(environ: MutableMapping[str, str] = os.environ) -> None:
    """Set ``GOMP_SPINCOUNT`` to :data:`SPIN_COUNT` unless ``OMP_WAIT_POLICY`` or
    ``GOMP_SPINCOUNT`` is already set."""
    if "OMP_WAIT_POLICY" in environ or "GOMP_SPINCOUNT" in environ:
        return
    environ["GOMP_SPINCOUNT"] = SPIN_COUNT
