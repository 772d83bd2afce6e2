"""Integration error of every plant's env at its sub-step count and at fewer sub-steps.

The step rate of a vector env is set by the RK4 sub-steps per env step (``bench/step_rate.py
--profile``: the kernel takes most of a step). This bench shows what fewer sub-steps would cost
in accuracy. Per plant (its first env id):

1. a ``--copies``-copy vector env (domain-randomised draws) is reset and run ``--warmup`` steps
   under random actions; its states, parameters and sub-step counts are the snapshot;
2. the run goes on ``--steps`` steps under random actions held for ``--hold`` steps, and the
   plant inputs the env applied at each step are recorded;
3. from the snapshot, the plant's own step kernel replays those inputs with every copy's
   sub-step count times each factor of ``--factors`` (at least 1), and with ``--reference``
   times it (the reference);
4. printed per factor: the mean sub-step count, and for each compared state the NRMSE against
   the reference (RMS error over the reference's range, per copy; the median and the largest over
   the copies), or ``unstable`` when a copy left the finite numbers.

Compared states: the position or force channel and the pressures of each plant. No pass/fail:
the servo's targets in ``bench/step_rate.py`` (position NRMSE 1e-4, pressure 1e-3 against
Radau) are the project's reference point.

Usage: ``python bench/substep_accuracy.py [--plants NAME,...] [--factors 1,0.5,0.34]``
"""

from __future__ import annotations

import argparse
import math

import numpy as np

#: states compared per plant (names of ``STATE_NAMES``)
COMPARED = {
    "servo_cylinder": ("x", "p1", "p2"),
    "force_actuator": ("xs", "fm"),
    "load_sensing": ("x", "p_s", "p_l"),
    "rodless_cylinder": ("y", "pa", "pb"),
    "shaking_table": ("x", "pa", "pb"),
}


def record(env_id: str, copies: int, warmup: int, steps: int, hold: int, seed: int) -> dict:
    """Snapshot after ``warmup`` random steps and the plant inputs of the next ``steps``."""
    import gymnasium as gym

    import hydro_envs  # noqa: F401  (registers the envs)

    venv = gym.make_vec(env_id, num_envs=copies, vectorization_mode="vector_entry_point")
    venv.reset(seed=seed)
    b = venv.unwrapped.batch
    space = venv.single_action_space
    rng = np.random.default_rng(seed)

    def actions(k: int, held: np.ndarray | None) -> np.ndarray:
        if held is None or k % hold == 0:
            held = rng.uniform(space.low, space.high, (copies,) + space.shape).astype(space.dtype)
        return held

    held = None
    for k in range(warmup):
        held = actions(k, held)
        venv.step(held)
    snap = {"Y": b.Y.copy(), "P": b.P.copy(), "NSUB": b.NSUB.copy(), "dt": float(b.dt),
            "W": np.zeros_like(b.W), "spec": b.plant_spec}
    kern = b.plant_spec.kernels
    snap["step"] = kern.pick(b.P).step_parallel
    inputs = []
    for k in range(steps):
        held = actions(k, held)
        venv.step(held)
        inputs.append(b.U.copy())
    venv.close()
    snap["U"] = np.array(inputs)
    return snap


def replay(snap: dict, factor: float) -> tuple[np.ndarray, float]:
    """States ``(steps, copies, n_states)`` from the snapshot under the recorded inputs with
    ``max(1, round(NSUB * factor))`` sub-steps; and the mean sub-step count."""
    nsub = np.maximum(1, np.round(snap["NSUB"] * factor)).astype(np.int64)
    Y = snap["Y"].copy()
    W = snap["W"].copy()
    clamps = np.zeros(Y.shape[0], dtype=np.int64)
    out = np.empty((snap["U"].shape[0],) + Y.shape)
    for k, U in enumerate(snap["U"]):
        snap["step"](Y, np.ascontiguousarray(U), snap["P"], snap["dt"], nsub, W, clamps)
        out[k] = Y
    return out, float(nsub.mean())


def nrmse(x: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Per copy: RMS of ``x - ref`` over time, over the range of ``ref``; inf where not finite."""
    with np.errstate(over="ignore", invalid="ignore"):
        err = np.sqrt(np.mean((x - ref) ** 2, axis=0))
    span = np.ptp(ref, axis=0)
    out = err / np.where(span > 0, span, 1.0)
    out[~np.all(np.isfinite(x), axis=0)] = math.inf
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--plants", default=",".join(COMPARED), help="plant names, comma-separated")
    ap.add_argument("--factors", default="1,0.5,0.34", help="sub-step count factors, comma-separated")
    ap.add_argument("--reference", type=float, default=16.0, help="sub-step factor of the reference")
    ap.add_argument("--copies", type=int, default=32)
    ap.add_argument("--warmup", type=int, default=300)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--hold", type=int, default=5, help="env steps each random action is held")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    from hydro_envs import registry

    factors = [float(f) for f in args.factors.split(",")]
    print(f"NRMSE against {args.reference:g}x the sub-steps, {args.copies} randomised copies, {args.steps} steps "
          f"after {args.warmup}; median / largest over the copies")
    for name in args.plants.split(","):
        spec = registry.get(name)
        env_id = spec.envs[0].id
        snap = record(env_id, args.copies, args.warmup, args.steps, args.hold, args.seed)
        idx = [spec.state_names.index(s) for s in COMPARED[name]]
        ref, _ = replay(snap, args.reference)
        print(f"{env_id}")
        for f in factors:
            x, mean_nsub = replay(snap, f)
            cells = []
            for s, j in zip(COMPARED[name], idx):
                e = nrmse(x[:, :, j], ref[:, :, j])
                cells.append(f"{s} unstable" if not np.all(np.isfinite(e))
                             else f"{s} {np.median(e):.1e} / {e.max():.1e}")
            print(f"  x{f:<5g} {mean_nsub:5.2f} sub-steps   " + "   ".join(cells))


if __name__ == "__main__":
    main()
