r"""The main job (``make demo``, ``hydro demo``): identify, calibrate, train, benchmark -- on a task
where friction decides.

One script that walks through what the suite is for, on the servo cylinder of seed 002 creeping
through velocity reversals (``hydro_envs/ServoCylinderSlowSine-v0``: 0.2-1.6 mm/s, below the seals'
Stribeck velocity, on a 1 um scale; the PID's ``friction_share``, the share of its squared error
that dry friction causes, is about 0.6):

1. **Identify** the friction of the "rig" -- the nominal servo cylinder seen through realistic
   sensors (0.03 mm encoder, 20 kPa pressure noise low-passed at 50 Hz,
   :meth:`hydro_envs.data.sensors.SensorModel.realistic`) -- from the virtual
   constant-velocity square-wave test of 002 sec. 4
   (:func:`~hydro_envs.plants.servo_cylinder.friction_test.run_friction_experiment`, plateau velocities and
   ``A (p_1 - p_2)`` per plateau, eq (10)), and fit the Stribeck law 002 eq (1) by nonlinear
   least squares (:func:`identification.friction.fit_friction`). The fit is printed beside the
   rig's true values, with standard errors.
2. **Calibrate** the classical controllers: the PID with load-pressure feedback and velocity
   feed-forward from the plant's linearisation without dry friction
   (:func:`agents.controllers.servo_cylinder.pid_tuning`; ``pid_vff``, blind to friction), and the
   same loop with the Stribeck law just identified in its pressure target
   (:class:`agents.controllers.tracking.PressureLoopPID`; ``pid_vff_identified``). The identified
   friction is checked against the training randomisation ranges: the learned agent must have
   seen the rig.
3. **Train** a residual PPO agent with domain randomisation (:func:`agents.train.train`,
   ``configs/agents/residual/ppo.yml``: a learned correction of at most 1 % of the valve command on
   top of ``pid_vff``, :mod:`agents.residual`; the batched-kernel SB3 adapter, rich progress bar).
   ``--pretrained`` skips training and uses the shipped agent (``agents/pretrained/``).
4. **Benchmark** the PID, ``pid_vff``, ``pid_vff_identified`` and the agent on the same ``--n``
   (20) frozen, seeded parameter draws from the training ranges (``in``) and beyond them
   (``out``) (:func:`agents.benchmark.run_benchmark`): every controller is also run on the same
   draws without dry friction, which gives its ``friction_share``. The tables are printed, and
   markdown, CSV and figures (box plots per metric, example traces, the friction fit) written to
   ``--out``.

Usage::

    python -m agents.demo [--out runs/demo] [--timesteps N] [--n 20] [--seed 0] [--pretrained] [--quick]
"""

from __future__ import annotations

import hydro_envs  # noqa: F401  (registers the envs)

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Callable, Sequence  # noqa: E402

import numpy as np  # noqa: E402

from hydro_envs.config_files import config_file  # noqa: E402

ENV_ID = "hydro_envs/ServoCylinderSlowSine-v0"
DEFAULT_TIMESTEPS = {"ppo": 400_000, "sac": 60_000}
QUICK_TIMESTEPS = {"ppo": 65_536, "sac": 12_000}
#: the agent's training config: residual PPO on top of pid_vff (configs/agents/residual/ppo.yml)
RESIDUAL_CONFIG = config_file("agents", "residual", "ppo.yml")
#: the shipped agent of the demo's task (python -m agents.demo --out DIR, then export_compact)
PRETRAINED_AGENT = Path(__file__).resolve().parent / "pretrained" / "demo" / "ppo_residual_s0"
BLIND_TWIN = "pid_vff"
FF_NAME = "pid_vff_identified"
FF_SPEC = "identified:stribeck"  # policy_loader key of the calibrated feedforward controller
STRIBECK_FIELDS = (  # fit parameter -> ServoCylinderParams field, unit, display scale
    ("F_c", "coulomb_friction", "N", 1.0),
    ("F_s", "static_friction", "N", 1.0),
    ("v_s", "stribeck_velocity", "mm/s", 1e3),
    ("F_v", "viscous_friction", "N s/m", 1.0),
)


class Stage:
    """Prints numbered stage headers and their wall times (the demo's progress)."""

    def __init__(self, total: int, console: Any) -> None:
        self.total, self.k, self.console = total, 0, console
        self.t0 = time.perf_counter()
        self.times: list[tuple[str, float]] = []
        self._t = self.t0
        self._title = ""

    def start(self, title: str) -> None:
        self.k += 1
        self._title, self._t = title, time.perf_counter()
        self.console.rule(f"[bold][{self.k}/{self.total}] {title}")

    def done(self) -> float:
        dt = time.perf_counter() - self._t
        self.times.append((self._title, dt))
        self.console.print(f"[dim]... {self._title.split(':')[0]} took {dt:.1f} s "
                           f"(total {time.perf_counter() - self.t0:.0f} s)[/dim]")
        return dt


# ------------------------------------------------------------------ 1. identify
def identify_friction(seed: int = 0):
    """Run the 002 sec. 4 test on the nominal rig with realistic sensors and fit 002 eq (1).

    Returns ``(fit, points, experiment)``. The plant's seals follow eq (1) with the sign
    function at constant velocity (their LuGre law's steady state), so the fit uses sign(v).
    """
    from hydro_envs.data.sensors import SensorModel
    from hydro_envs.plants.servo_cylinder.friction_test import run_friction_experiment
    from identification.constant_velocity import friction_points_from_square_wave
    from identification.friction import fit_friction

    exp = run_friction_experiment(sensors=SensorModel.realistic(), seed=seed, period_max=3.0)
    points = friction_points_from_square_wave(exp.data)
    fit = fit_friction(points, model="stribeck")
    return fit, points, exp


def friction_table(fit: Any, truth: Any) -> list[tuple[str, str, float, float, float]]:
    """Rows ``(name, unit, identified, std error, rig value)`` in display units."""
    rows = []
    for name, field, unit, scale in STRIBECK_FIELDS:
        rows.append((name, unit, fit.parameters[name] * scale, fit.std_errors.get(name, np.nan) * scale,
                     getattr(truth, field) * scale))
    return rows


def inside_training_ranges(fit: Any) -> list[tuple[str, float, float, float, bool]]:
    """``(field, identified, low, high, inside)`` for the friction fields the env randomises."""
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
    from hydro_envs.randomization import load_randomization

    spec = load_randomization("servo_cylinder", ServoCylinderParams)
    ranges = {r["name"]: r["value_range"] for r in spec.table()}
    out = []
    for name, field, _, _ in STRIBECK_FIELDS:
        if field in ranges:
            lo, hi = ranges[field]
            val = fit.parameters[name]
            out.append((field, val, lo, hi, bool(lo <= val <= hi)))
    return out


def friction_figure(fit: Any, points: Any, truth: Any, path: Path) -> Path | None:
    """Measured plateau points, the identified law and the rig's law (PNG); None without
    matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover - plotting extra not installed
        return None
    from identification.friction import static_friction

    v = np.asarray(points.v)
    vv = np.linspace(v.min(), v.max(), 801)
    true_params = {name: getattr(truth, field) for name, field, _, _ in STRIBECK_FIELDS}
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot(v * 1e3, points.force, "o", ms=3, label="plateaus of the virtual test (noisy sensors)")
    ax.plot(vv * 1e3, fit.predict(vv), "-", label="identified Stribeck law, 002 eq (1)")
    ax.plot(vv * 1e3, static_friction("stribeck", vv, true_params, None, 0.0),
            "--", label="rig (truth)")
    ax.set_xlabel("piston velocity [mm/s]")
    ax.set_ylabel("friction force A (p1 - p2) [N]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    from hydro_envs.outputs import atomic_path

    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110)
    finally:
        plt.close(fig)
    return path


# ------------------------------------------------------------------ 2. calibrate
def calibrated_controllers(fit: Any) -> tuple[Any, Any, dict[str, float]]:
    """``(pid_vff, pid_vff_identified, tuning)``: the PID with velocity feed-forward from the
    nominal linearisation and the same loop with the identified friction law in its pressure
    target."""
    from agents.controllers.servo_cylinder import ServoPIDController, pid_tuning
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams

    p = ServoCylinderParams()
    return (ServoPIDController.from_params(p, vff=True), ServoPIDController.from_params(p, vff=True, model=fit),
            pid_tuning(p))


# ------------------------------------------------------------------ 3. train
def free_run_name(out: Path, base: str) -> str:
    """``base``, or ``base_2``, ``base_3``, ... : the first name under ``out`` that is not a
    non-empty folder (a rerun of the demo keeps the earlier agent and trains beside it)."""
    name, k = base, 1
    while (out / name).exists() and any((out / name).iterdir()):
        k += 1
        name = f"{base}_{k}"
    return name


def train_agent(algo: str, timesteps: int, seed: int, out: Path, progress_bar: bool = True) -> Path:
    """:func:`agents.train.train` of the residual agent (:data:`RESIDUAL_CONFIG`; PPO only) with
    randomisation into ``out/<algo>_residual_seed<seed>`` (or the next free name,
    :func:`free_run_name`); returns the run folder."""
    from agents.train import train

    config = RESIDUAL_CONFIG if algo == "ppo" else None
    return train(ENV_ID, algo, timesteps=timesteps, seed=seed, randomize=True, out=out, config=config,
                 name=free_run_name(Path(out), f"{algo}_residual_seed{seed}"), progress_bar=progress_bar,
                 eval_freq=0, n_eval_episodes=8, torch_threads=1)


def pretrained_run(algo: str = "ppo") -> Path:
    """The shipped agent of the demo's task (:data:`PRETRAINED_AGENT`)."""
    if algo != "ppo":
        raise ValueError(f"--pretrained has a PPO agent only, not {algo!r}")
    if not (PRETRAINED_AGENT / "policy.pt").is_file():
        raise FileNotFoundError(f"{PRETRAINED_AGENT} has no policy; train one with python -m agents.demo")
    return PRETRAINED_AGENT


# ------------------------------------------------------------------ 4. benchmark
def benchmark(agent_run: Path, algo: str, ff_controller: Any, n: int, seed: int, out: Path,
              params: str, progress: Callable[[str], None]):
    """PID, its friction-blind twin with velocity feed-forward, the same with the identified
    friction and the agent on ``n`` frozen draws of ``params``."""
    from agents.benchmark import _load_policy, run_benchmark

    def loader(spec: str) -> Any:  # the calibrated controller is built here, not by name
        return ff_controller if spec == FF_SPEC else _load_policy(spec)

    specs = ["pid", BLIND_TWIN, f"{FF_NAME}=sb3:{FF_SPEC}", f"{algo}=sb3:{agent_run}"]
    return run_benchmark(ENV_ID, specs, params=params, n=n, seed=seed, out_dir=out,
                         policy_loader=loader, progress=progress)


SUMMARY_METRICS = (  # key, label, scale
    ("rmse", "RMSE [um]", 1e6),
    ("max_error", "max error [um]", 1e6),
    ("rmse_rel_pid", "RMSE / PID", 1.0),
    ("friction_share", "friction share", 1.0),
    ("reversal_error", "reversal error [um]", 1e6),
    ("reversal_excess", "reversal excess [um]", 1e6),
    ("effort", "effort (RMS action)", 1.0),
    ("pressure_violations", "p-violation steps", 1.0),
    ("endstop_steps", "end-stop steps", 1.0),
    ("failed", "failure rate", 1.0),
    ("cvar10_rmse", "CVaR10 RMSE [um]", 1e6),
)


def print_benchmark(res: Any, console: Any) -> None:
    from rich.table import Table

    from rich.markup import escape

    tab = Table(title=escape(f"{res.env_id}: params = {res.params}, n = {res.n} frozen draws (mean [95 % CI])"))
    tab.add_column("metric")
    for c in res.summary:
        tab.add_column(c, justify="right")
    for key, label, scale in SUMMARY_METRICS:
        if not all(key in s for s in res.summary.values()):
            continue
        cells = []
        for s in res.summary.values():
            m, lo, hi, _ = s[key]
            cells.append("n/a" if not np.isfinite(m) else f"{m * scale:.3g} [{lo * scale:.3g}, {hi * scale:.3g}]")
        tab.add_row(escape(label), *(escape(c) for c in cells))
    console.print(tab)


def verdict(results: Sequence[Any], algo: str) -> list[str]:
    """One honest sentence per parameter set: how much of the PID's error friction makes, and
    what the identified friction and the agent do against the same loop blind to it."""
    lines = []
    for res in results:
        s = res.summary
        share = s["pid"]["friction_share"]
        rel = {c: s[c]["rmse_rel_pid"] for c in (BLIND_TWIN, FF_NAME, algo)}
        ff_twin = s[FF_NAME]["rmse"][0] / s[BLIND_TWIN]["rmse"][0]
        lines.append(f"{res.params}: dry friction makes {share[0]:.2f} [{share[1]:.2f}, {share[2]:.2f}] of the PID's "
                     f"squared error; RMSE / PID (paired): {BLIND_TWIN} {rel[BLIND_TWIN][0]:.2f}, {FF_NAME} "
                     f"{rel[FF_NAME][0]:.2f} [{rel[FF_NAME][1]:.2f}, {rel[FF_NAME][2]:.2f}] ({ff_twin:.2f} x its blind "
                     f"twin), {algo} {rel[algo][0]:.2f} [{rel[algo][1]:.2f}, {rel[algo][2]:.2f}]")
    return lines


# ------------------------------------------------------------------ main
def run(out: str | Path = "runs/demo", *, algo: str = "ppo", timesteps: int | None = None, n: int = 20,
        seed: int = 0, pretrained: bool = False, quick: bool = False, params: Sequence[str] = ("in", "out"),
        progress_bar: bool = True, agent_run: str | Path | None = None) -> dict[str, Any]:
    """Run the four stages; return a summary dict (fit, run folder, benchmark results, times).

    ``agent_run``: an existing run folder (of :mod:`agents.train` or a compact one) to benchmark
    instead of training; ``pretrained``: the shipped baseline.
    """
    from rich.console import Console

    console = Console()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if algo not in DEFAULT_TIMESTEPS:
        raise ValueError(f"algo = {algo!r}; allowed {tuple(DEFAULT_TIMESTEPS)}")
    if timesteps is None:
        timesteps = (QUICK_TIMESTEPS if quick else DEFAULT_TIMESTEPS)[algo]
    if timesteps < 1:
        raise ValueError(f"timesteps must be >= 1, got {timesteps}")
    if n < 2:
        raise ValueError(f"n must be >= 2 draws (confidence intervals), got {n}")
    stage = Stage(4, console)
    console.print(f"[bold]hydro-envs demo[/bold]: identify -> calibrate -> train -> benchmark on {ENV_ID}; "
                  f"outputs in {out}/")

    stage.start("Identify: friction from the virtual constant-velocity test (002 sec. 4)")
    fit, points, exp = identify_friction(seed)
    console.print(f"{len(points.v)} constant-velocity plateaus from a {exp.data.t[-1]:.0f} s square-wave test, "
                  "realistic sensors (0.03 mm encoder, 20 kPa pressure noise, 50 Hz filter)")
    from rich.markup import escape
    from rich.table import Table

    tab = Table(title="Stribeck law 002 eq (1), nonlinear least squares")
    for col in ("parameter", "identified", "std error", "rig (truth)", "error"):
        tab.add_column(col, justify="right")
    for name, unit, val, se, true in friction_table(fit, exp.params):
        tab.add_row(escape(f"{name} [{unit}]"), f"{val:.4g}", f"{se:.2g}", f"{true:.4g}", f"{100 * (val - true) / true:+.1f} %")
    console.print(tab)
    fig = friction_figure(fit, points, exp.params, out / "friction_fit.png")
    stage.done()

    stage.start("Calibrate: PID from the linearisation, feedforward from the identified friction")
    pid, pid_ff, tuning = calibrated_controllers(fit)
    console.print(f"PID: omega_h = {tuning['omega_h']:.0f} rad/s at mid-stroke, crossover omega_c = "
                  f"{tuning['omega_c']:.1f} rad/s, K_p = {tuning['kp']:.1f} 1/m, T_i = {tuning['ti'] * 1e3:.0f} ms, "
                  f"T_d = {tuning['td'] * 1e3:.2f} ms, load-pressure gain k_dp = {tuning['k_dp']:g}")
    console.print(f"{BLIND_TWIN}: the PID + velocity feed-forward, blind to friction; {FF_NAME}: the same loop "
                  "with the identified friction in its load-pressure target (it swings the pressure ahead of "
                  "each reversal)")
    for field, val, lo, hi, ok in inside_training_ranges(fit):
        console.print(f"  {field:>18} = {val:.4g}  training range [{lo:.4g}, {hi:.4g}]  "
                      + ("[green]inside[/green]" if ok else "[red]OUTSIDE: the agent never saw this rig[/red]"))
    stage.done()

    if pretrained or agent_run is not None:
        run_dir = Path(agent_run) if agent_run is not None else pretrained_run(algo)
        stage.start(f"Train: skipped, using {'the shipped baseline' if agent_run is None else 'a given run'}")
        console.print(f"agent: {run_dir}")
    else:
        stage.start(f"Train: residual {algo.upper()} for {timesteps:,} steps with domain randomisation")
        run_dir = train_agent(algo, timesteps, seed, out / "agents", progress_bar=progress_bar)
        console.print(f"run folder: {run_dir}")
    stage.done()

    stage.start(f"Benchmark: PID, {BLIND_TWIN}, {FF_NAME} and {algo.upper()} on {n} frozen draws (and without "
                "dry friction)")
    results = []
    for ps in params:
        res = benchmark(run_dir, algo, pid_ff, n, seed, out, ps, progress=lambda m: console.print(f"  {m}"))
        print_benchmark(res, console)
        results.append(res)
    stage.done()

    console.rule("[bold]Summary")
    for line in verdict(results, algo):
        console.print(line)
    files = sorted({str(f) for r in results for f in r.files} | ({str(fig)} if fig else set()))
    console.print("files: " + ", ".join(files))
    total = time.perf_counter() - stage.t0
    console.print("stage times: " + ", ".join(f"{t.split(':')[0]} {s:.0f} s" for t, s in stage.times)
                  + f"; total {total:.0f} s")
    return {"fit": fit, "run_dir": run_dir, "results": results, "times": stage.times, "total_s": total,
            "files": files}


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="runs/demo",
                   help="output folder (default runs/demo); a non-empty folder only with --force")
    p.add_argument("--force", action="store_true", help="write into a non-empty --out folder (replacing its files)")
    p.add_argument("--algo", choices=tuple(DEFAULT_TIMESTEPS), default="ppo")
    p.add_argument("--timesteps", type=int, default=None,
                   help=f"training steps (default {DEFAULT_TIMESTEPS}; --quick {QUICK_TIMESTEPS})")
    p.add_argument("--n", type=int, default=20, help="frozen parameter draws per set (default 20)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--params", nargs="+", default=["in", "out"], choices=("nominal", "in", "out"))
    p.add_argument("--pretrained", action="store_true", help="skip training: use agents/pretrained/")
    p.add_argument("--quick", action="store_true", help="a short smoke run (few training steps)")
    p.add_argument("--no-progress-bar", action="store_true")
    p.add_argument("--rollouts", action="store_true",
                   help="only a quick look: randomised episodes under a P controller (no training)")
    p.add_argument("--episodes", type=int, default=5, metavar="N", help="(--rollouts) episodes")


def _run_args(a: argparse.Namespace) -> int:
    """Run the demo; errors propagate to the command line's one-line convention
    (:mod:`hydro_envs.cli_errors`). ``--out`` is checked before the work."""
    if a.rollouts:
        from agents.rollouts import run_demo

        return run_demo(episodes=a.episodes, seed=a.seed)
    from hydro_envs.outputs import check_output_dir

    for name in ("n", "timesteps", "episodes"):
        v = getattr(a, name)
        if v is not None and v < 1:
            raise ValueError(f"--{name} = {v}; allowed an integer >= 1")
    check_output_dir(a.out, force=bool(a.force))
    run(a.out, algo=a.algo, timesteps=a.timesteps, n=a.n, seed=a.seed, pretrained=a.pretrained,
        quick=a.quick, params=a.params, progress_bar=not a.no_progress_bar)
    return 0


def add_cli(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``hydro demo`` on an argparse subparsers object."""
    p = subparsers.add_parser(
        "demo",
        help="the main job: identify friction, calibrate, train a residual agent, benchmark on a friction task",
        description="The main job, on the servo cylinder creeping through reversals (a task where "
        "friction decides): identify its friction from a virtual constant-velocity test, calibrate "
        "the PID and the same loop with the identified friction, train a residual PPO agent with "
        "domain randomisation, benchmark them on frozen parameter draws (with and without dry "
        "friction) and write tables and figures. --rollouts runs a quick look instead: randomised "
        "episodes under a P controller.",
    )
    _add_arguments(p)
    p.set_defaults(func=_run_args)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    from hydro_envs.cli_errors import Parser, guarded

    p = Parser(prog="python -m agents.demo", description=__doc__.split("\n\n")[0])
    _add_arguments(p)
    return guarded("python -m agents.demo", _run_args, p.parse_args(argv))


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
