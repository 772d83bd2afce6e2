r"""Run independent pieces of work serially or as Ray core tasks.

The benchmark, the diagnosis sweep and multi-seed training all consist of independent pieces
(a controller on a chunk of frozen draws, one hidden-effect case, one training seed). This
module runs such pieces either in this process (``backend="serial"``, the default) or as Ray
*core tasks* (``backend="ray"``): one ``@ray.remote`` function call per piece, results
returned in input order. Nothing here schedules work itself -- Ray does.

Why tasks that batch many evaluations: a Ray task costs milliseconds to submit and a fresh
worker pays the import and numba cache load once, so a task must carry enough work (a whole
vector-env batch, a whole diagnosis case, a whole training run) to be worth shipping; tasks of
single episodes were measured slower than serial. :func:`run_tasks` therefore ships exactly the
calls it is given; :func:`map_chunks` groups per-item work into contiguous chunks, one task
per chunk.

Determinism: every piece is a pure function of its arguments (seeds included), so the
backend, the chunking and the completion order do not change any result. The callers keep the
seeds attached to the items (the benchmark passes each chunk its draw offset, so copy ``i``
is still reset with ``seed + i``).

Ray is an optional extra (``pip install hydro-envs[ray]``) and is imported only when the
``ray`` backend is used. Where Ray runs:

* ``address`` argument, else the ``RAY_ADDRESS`` environment variable: connect to that cluster
  (``"auto"`` = the cluster started on this machine with ``ray start --head``); the package
  must be installed on every node and output folders must be on a shared filesystem;
* otherwise a local Ray with ``num_cpus`` CPUs (default ``os.cpu_count()``), no dashboard;
  its workers get this source tree on ``PYTHONPATH`` so a checkout works without installing;
* an already initialised Ray (``ray.init(...)`` by the caller) is used as it is.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, TypeVar

__all__ = [
    "BACKENDS",
    "RAY_INSTALL_HINT",
    "add_backend_args",
    "check_backend",
    "chunk_ranges",
    "cluster_cpus",
    "ensure_ray",
    "import_ray",
    "map_chunks",
    "run_tasks",
]

T = TypeVar("T")
R = TypeVar("R")

BACKENDS = ("serial", "ray")
RAY_INSTALL_HINT = "pip install hydro-envs[ray]"
_ROOT = Path(__file__).resolve().parents[1]  # the folder holding agents/, hydro_envs/, identification/


def check_backend(backend: str) -> str:
    """Return ``backend`` if it is one of :data:`BACKENDS`, else raise naming the allowed ones."""
    if backend not in BACKENDS:
        raise ValueError(f"backend = {backend!r}; allowed {', '.join(BACKENDS)}")
    return backend


def import_ray() -> ModuleType:
    """``import ray`` with an error that says how to install it (the extra is optional)."""
    try:
        import ray
    except ImportError as exc:
        raise ImportError(f"the 'ray' backend needs Ray, which is not installed: {RAY_INSTALL_HINT}") from exc
    return ray


def ensure_ray(address: str | None = None, num_cpus: int | None = None) -> ModuleType:
    """The ``ray`` module with a connected Ray (see the module docstring for where it runs)."""
    ray = import_ray()
    if ray.is_initialized():
        return ray
    address = address or os.environ.get("RAY_ADDRESS") or None
    if address:
        if num_cpus is not None:
            raise ValueError(f"num_cpus = {num_cpus} only sizes a local Ray; the cluster at {address!r} "
                             "has its own CPUs (drop num_cpus or the address)")
        ray.init(address=address)
        return ray
    if num_cpus is None:
        num_cpus = os.cpu_count() or 1
    if not (isinstance(num_cpus, int) and num_cpus >= 1):
        raise ValueError(f"num_cpus must be an integer >= 1, got {num_cpus!r}")
    # local workers are fresh interpreters started by the raylet: give them this source tree
    # so they import the same code as this process even when the package is not installed
    path = os.pathsep.join(p for p in (str(_ROOT), os.environ.get("PYTHONPATH", "")) if p)
    ray.init(num_cpus=num_cpus, include_dashboard=False, runtime_env={"env_vars": {"PYTHONPATH": path}})
    return ray


def cluster_cpus(backend: str = "serial", address: str | None = None, num_cpus: int | None = None) -> int:
    """CPUs the work can spread over: 1 for ``serial``, the Ray cluster's CPUs for ``ray``."""
    if check_backend(backend) == "serial":
        return 1
    ray = ensure_ray(address, num_cpus)
    return max(1, int(ray.cluster_resources().get("CPU", 1)))


def chunk_ranges(n: int, chunk_size: int) -> list[tuple[int, int]]:
    """Contiguous ``[lo, hi)`` ranges covering ``range(n)``, each at most ``chunk_size`` long."""
    if not (isinstance(n, int) and n >= 0):
        raise ValueError(f"n must be an integer >= 0, got {n!r}")
    if not (isinstance(chunk_size, int) and chunk_size >= 1):
        raise ValueError(f"chunk_size must be an integer >= 1, got {chunk_size!r}")
    return [(lo, min(lo + chunk_size, n)) for lo in range(0, n, chunk_size)]


def _limit_threads(cpus: float) -> None:
    """Keep a task's thread pools within the CPUs Ray reserved for it.

    Ray sets ``OMP_NUM_THREADS`` for its workers, but numba's pool (parallel kernels of large
    batches) and torch size themselves by the machine's cores; two tasks on two CPUs would
    otherwise each start a thread per core and slow each other down. Per-copy kernels give the
    same numbers with any thread count.
    """
    k = max(1, int(cpus))
    try:
        import numba

        numba.set_num_threads(min(k, numba.config.NUMBA_NUM_THREADS))
    except ImportError:  # pragma: no cover - numba is a core dependency
        pass
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(k)


def _call(fn: Callable[..., R], args: tuple, cpus: float) -> R:
    """Body of every Ray task: bound the threads, then run ``fn(*args)``."""
    _limit_threads(cpus)
    return fn(*args)


def _apply_chunk(fn: Callable[[T], R], chunk: Sequence[T]) -> list[R]:
    return [fn(x) for x in chunk]


_REMOTE: list[Any] = []  # the remote version of _call, made once per process


def run_tasks(
    fn: Callable[..., R],
    calls: Iterable[tuple],
    *,
    backend: str = "serial",
    address: str | None = None,
    num_cpus: int | None = None,
    task_cpus: float = 1.0,
    on_result: Callable[[int, R], None] | None = None,
) -> list[R]:
    """``[fn(*args) for args in calls]``, serially or as one Ray task per call.

    Results are in the order of ``calls``; ``on_result(i, result)`` is called in that order as
    soon as result ``i`` and all before it are available (progress output). ``task_cpus``: CPUs
    Ray reserves per task (and the thread count the task may use). ``fn`` and the arguments
    must be picklable (module-level functions; lambdas and closures travel by value). An
    exception raised by a task is re-raised here as the original exception (type and message;
    the remote traceback is chained as its cause) as soon as it is the earliest unfinished
    result; tasks still running are left to finish (see below).
    """
    calls = [tuple(c) for c in calls]
    out: list[R] = []
    if check_backend(backend) == "serial":
        for i, args in enumerate(calls):
            out.append(fn(*args))
            if on_result is not None:
                on_result(i, out[-1])
        return out
    if not (task_cpus > 0):
        raise ValueError(f"task_cpus must be > 0, got {task_cpus!r}")
    if not calls:
        return out
    ray = ensure_ray(address, num_cpus)
    if not _REMOTE:
        _REMOTE.append(ray.remote(_call))
    task = _REMOTE[0].options(num_cpus=task_cpus)
    fn_ref = ray.put(fn)  # shipped once, not with every task
    refs = [task.remote(fn_ref, args, task_cpus) for args in calls]
    try:
        for i, ref in enumerate(refs):
            out.append(ray.get(ref))
            if on_result is not None:
                on_result(i, out[-1])
    except ray.exceptions.RayTaskError as err:
        # The other tasks are not cancelled: ray.cancel on a task that is just completing
        # aborted the whole driver process in Ray 2.60 (a failed RAY_CHECK in task_manager.cc,
        # seen in this module's tests). They finish and their results are dropped; a local Ray
        # stops them when this process exits.
        cause = getattr(err, "cause", None)
        if isinstance(cause, BaseException):
            raise cause from err
        raise
    return out


def map_chunks(
    fn: Callable[[T], R],
    items: Sequence[T],
    *,
    backend: str = "serial",
    chunk_size: int | None = None,
    address: str | None = None,
    num_cpus: int | None = None,
    task_cpus: float = 1.0,
    on_result: Callable[[int, R], None] | None = None,
) -> list[R]:
    """``[fn(x) for x in items]``; with Ray, one task per contiguous chunk of ``chunk_size`` items.

    Default ``chunk_size``: two chunks per CPU of the cluster (fewer, larger tasks keep the
    per-task overhead small; two per CPU leave room to balance items of unequal cost). Serial:
    items one after the other, no chunking. ``on_result(i, result)`` per item, in order.
    Errors: as :func:`run_tasks`.
    """
    items = list(items)
    if check_backend(backend) == "serial" or not items:
        return run_tasks(fn, [(x,) for x in items], backend="serial", on_result=on_result)
    if chunk_size is None:
        cpus = cluster_cpus(backend, address, num_cpus)
        chunk_size = max(1, math.ceil(len(items) / (2 * cpus)))
    ranges = chunk_ranges(len(items), chunk_size)
    out: list[R] = []

    def collect(k: int, chunk_result: list[R]) -> None:
        for r in chunk_result:
            if on_result is not None:
                on_result(len(out), r)
            out.append(r)

    run_tasks(_apply_chunk, [(fn, items[lo:hi]) for lo, hi in ranges], backend=backend, address=address,
              num_cpus=num_cpus, task_cpus=task_cpus, on_result=collect)
    return out


def add_backend_args(parser: Any) -> None:
    """``--backend``, ``--ray-address`` and ``--num-cpus`` on an argparse parser."""
    parser.add_argument("--backend", choices=BACKENDS, default="serial",
                        help="serial (default) or ray: Ray core tasks, identical results "
                             f"(needs the extra: {RAY_INSTALL_HINT})")
    parser.add_argument("--ray-address", metavar="ADDR", default=None,
                        help="Ray cluster to connect to (default: $RAY_ADDRESS, else a local Ray)")
    parser.add_argument("--num-cpus", type=int, metavar="N", default=None,
                        help="CPUs of the local Ray (default: all of this machine)")
