"""Ablation of the friction model in the best friction-aware controller of each friction task.

For each task the controller's friction target is scaled by 0, 0.5, 1, 1.5 and 2
(``friction_scale``; 0 is its blind twin, 1 the model as identified) and run on the same 20
``in`` draws and episodes as the benchmark (seed 0); printed: the paired RMSE over the PID's,
mean with a 95 % percentile-bootstrap interval over the draws (:mod:`agents.benchmark_stats`).
A gain that comes from the friction model falls towards the blind twin as the scale goes to 0
and grows again when the model is over-scaled.

Usage: ``python bench/friction_ablation.py [--tasks NAME ...] [--n 20] [--markdown FILE [--force]]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from agents.benchmark import draw_parameters, rollout  # noqa: E402
from agents.benchmark_stats import draw_bootstrap_ci  # noqa: E402
from agents.controllers import make_controller  # noqa: E402
from hydro_envs.outputs import OutputError, atomic_write, check_output_file  # noqa: E402

#: task -> (env id, the best friction-aware controller of the task's benchmark and, for the servo,
#: the best pure feed-forward: the observer's scale multiplies its feedback on the error too)
TASKS = {
    "servo_cylinder_slow_sine": ("hydro_envs/ServoCylinderSlowSine-v0", ("pid_vff_lugre_observer", "pid_vff_lugre")),
    "rodless_cylinder_slow_sine": ("hydro_envs/RodlessCylinderSlowSine-v0", ("pid_dp_stribeck",)),
    "rodless_cylinder_micro_position": ("hydro_envs/RodlessCylinderMicroPosition-v0", ("pid_dp_stiction",)),
    "force_actuator_small_force": ("hydro_envs/ForceActuatorSmallForce-v0", ("pid_dahl",)),
}
SCALES = (0.0, 0.5, 1.0, 1.5, 2.0)


def _rmse(env_id: str, ctrl, draws) -> np.ndarray:
    ro = rollout(env_id, ctrl, draws, seed=0)
    return np.sqrt(np.mean((ro.ref - ro.y) ** 2, axis=0))


def ablation(env_id: str, name: str, n: int) -> list[tuple[float, float, float, float]]:
    """``[(scale, mean, low, high)]`` of the paired RMSE / PID."""
    draws = draw_parameters(env_id, "in", n, 0)
    pid = _rmse(env_id, make_controller(env_id, "pid"), draws)
    out = []
    for k in SCALES:
        ctrl = make_controller(env_id, name)
        ctrl.friction_scale = k
        m, lo, hi, _ = draw_bootstrap_ci(_rmse(env_id, ctrl, draws) / pid, seed=0)
        out.append((k, m, lo, hi))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", nargs="+", default=list(TASKS), choices=list(TASKS))
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--markdown", metavar="FILE", help="also write the table as markdown")
    ap.add_argument("--force", action="store_true", help="replace an existing --markdown file")
    a = ap.parse_args(argv)
    if a.markdown:  # checked before the work (hydro_envs.outputs: the command line's convention)
        try:
            check_output_file(a.markdown, flag="--markdown", force=a.force, suffixes=(".md",))
        except OutputError as exc:
            ap.exit(2, f"friction_ablation: error: {exc}\n")
    lines = ["| task | controller | " + " | ".join(f"x {k:g}" for k in SCALES) + " |",
             "|---|---|" + "---|" * len(SCALES)]
    for task in a.tasks:
        env_id, names = TASKS[task]
        for name in names:
            rows = ablation(env_id, name, a.n)
            cells = [f"{m:.3f} [{lo:.3f}, {hi:.3f}]" for _, m, lo, hi in rows]
            lines.append(f"| {task} | {name} | " + " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    if a.markdown:
        atomic_write(a.markdown, "\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
