r"""Identified friction models for the friction feedforward controllers.

The feedforward controllers never read the plant's friction parameters: they use a model
identified from a *virtual* constant-velocity experiment on the nominal plant, as a user of the
suite would on the rig, then fitted with the static Stribeck law
(:func:`identification.friction.fit_friction`, kind ``"stribeck"``) or with one of the two
neural friction nets of 002 sec. 5: the feed-forward net trained by Levenberg-Marquardt
(:func:`identification.neural.fit_feedforward`, 10 tanh units, kind ``"neural"``) or the RBF
net (:func:`identification.neural.fit_rbf`, 50 Gaussian units, kind ``"rbf"``).

Experiments (all on the nominal parameter set, ideal sensors):

* servo cylinder: the square-wave test of 002 sec. 4
  (:func:`hydro_envs.plants.servo_cylinder.friction_test.run_friction_experiment`, periods capped at 3 s: 68
  amplitudes 0.05-3.4 V in about 40 s instead of 150 s, then
  :func:`~identification.constant_velocity.friction_points_from_square_wave`); Stribeck law 002 eq (1)
  with the plant's sign regularisation.
* shaking table: constant valve commands held from one end of the stroke; the mean velocity
  and the mean pressure force ``A (P_a - P_b)`` while the table crosses the middle 40 % of the
  stroke give one point per command (003 eq (10) at zero acceleration); Gaussian Stribeck law
  003 eq (11) with the tanh sign of eq (12) (``v_eps = 1/beta`` of the nominal plant).
* rodless cylinder: 004 sec. 3 constant-command runs
  (:func:`hydro_envs.plants.rodless_cylinder.constant_command_run`, eq (1)); Stribeck law of
  004 Table 2.

Results are cached per process (:func:`functools.lru_cache`); each identification takes well
under a second.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

__all__ = ["CREEP_SPEEDS", "FRICTION_KINDS", "PerCopyFriction", "creep_points", "friction_plants", "friction_points",
           "identified_friction", "identified_presliding", "identify_on_draws"]

FRICTION_KINDS = ("stribeck", "neural", "rbf")


def _experiments() -> dict:
    from hydro_envs import registry

    from agents.controllers import controller_module

    out = {}
    for spec in registry.specs():
        mod = controller_module(spec.name) if spec.envs else None
        if mod is not None and hasattr(mod, "friction_points"):
            out[spec.name] = mod.friction_points
    return out


def friction_plants() -> tuple[str, ...]:
    """Plants whose controller module runs a virtual friction experiment."""
    return tuple(_experiments())


@functools.cache
def friction_points(plant: str):
    """``(points, sign_velocity, static_model)`` of the plant's virtual experiment (cached)."""
    experiments = _experiments()
    if plant not in experiments:
        raise ValueError(f"plant = {plant!r}; friction identification available for {sorted(experiments)}")
    return experiments[plant]()


@functools.cache
def identified_friction(plant: str, kind: str = "stribeck") -> Any:
    """Friction model ``F = model.predict(v)`` [N] identified on the nominal ``plant``.

    ``kind``: ``"stribeck"`` (static law, see the module docstring), ``"neural"`` (002 sec. 5
    feed-forward net, seed 0, 3 restarts) or ``"rbf"`` (002 sec. 5 RBF net, seed 0, :func:`_fit_net`).
    """
    from identification.friction import fit_friction

    if kind not in FRICTION_KINDS:
        raise ValueError(f"kind = {kind!r}; allowed {FRICTION_KINDS}")
    pts, v_eps, model = friction_points(plant)
    if isinstance(pts, tuple):
        v, f = pts
        if kind == "stribeck":
            return fit_friction(v, f, model=model, sign_velocity=v_eps)
        return _fit_net(kind, *_net_points(plant, v, f))
    if kind == "stribeck":
        return fit_friction(pts, model=model, sign_velocity=v_eps)
    return _fit_net(kind, *_net_points(plant, np.asarray(pts.v, float), np.asarray(pts.force, float)))


#: reference speeds [m/s] of the closed-loop creep test that extends the nets' data below the
#: open-loop test's slowest steady plateau (per plant: about 0.05-0.5 of its Stribeck velocity)
CREEP_SPEEDS = {"servo_cylinder": (0.5e-3, 1e-3, 2e-3, 4e-3), "rodless_cylinder": (0.3e-3, 0.6e-3, 1.2e-3, 2.4e-3)}


def creep_points(plant: str, speeds: Any = None, *, travel: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """Friction points ``(v, F)`` at creep speeds, measured in closed loop on the nominal rig:
    the plant's ``pid_vff`` tracks a ramp at each speed (both directions) across ``travel`` of
    the stroke about the middle, and over the middle half of each ramp the mean velocity and the
    mean pressure force ``A (p_1 - p_2)`` (the friction at steady speed, 002 eq (10) / 004 eq (1))
    give one point. Below the speed where the open-loop test of 002 sec. 4 / 004 sec. 3 sticks
    and slips the loop keeps the axis creeping, so the nets see the low-speed branch of the law
    (and its sign) instead of extrapolating to it; where the loop itself sticks and slips, the
    point is that cycle's mean force (below the steady curve). All ramps run as the copies of
    one vector env."""
    from gymnasium.envs.registration import load_env_creator
    import gymnasium as gym

    from agents.controllers import make_controller
    from hydro_envs import registry

    spec = registry.get(plant)
    env_id = next(e.id for e in spec.envs if "SlowSine" in e.id)
    speeds = np.asarray(CREEP_SPEEDS[plant] if speeds is None else speeds, dtype=float)
    ramps = [(v, sg) for v in speeds for sg in (1.0, -1.0)]
    cls = load_env_creator(gym.spec(env_id).vector_entry_point)
    probe = cls(num_envs=1, randomize=False)
    p, dt = probe.batch.base_params, probe.batch.dt
    probe.close()
    L = p.stroke
    lengths = [int(round(travel * L / v / dt)) + 1 for v, _ in ramps]
    steps = max(lengths)
    venv = cls(num_envs=len(ramps), randomize=False, max_episode_steps=steps)
    b = venv.batch
    b.parallel = False  # eight copies: the serial kernel (a parallel region costs more to enter)
    venv.reset(seed=0)
    for i, ((v, sg), n) in enumerate(zip(ramps, lengths)):
        ramp = 0.5 * L - sg * 0.5 * travel * L + sg * v * dt * np.arange(n)
        ref = np.r_[ramp, np.full(steps + 60 - n, ramp[-1])]
        mask = np.zeros(len(ramps), dtype=bool)
        mask[i] = True
        obs, _ = venv.reset(seed=0, options={"reset_mask": mask, "reference": ref,
                                            "state": {b.position_name: float(ref[0])}})
    area_of = spec.contract.piston_area
    area = area_of(p) if area_of is not None else p.piston_area
    ip1, ip2 = b.pressure_indices
    ctrl = make_controller(env_id, "pid_vff")
    X = np.empty((steps, len(ramps)))
    F = np.empty((steps, len(ramps)))
    start = np.ones(len(ramps), dtype=bool)
    for k in range(steps):
        a, _ = ctrl.predict(obs, episode_start=start)
        start[:] = False
        obs, *_ = venv.step(a)
        X[k] = b.Y[:, b.position_index]
        F[k] = area * (b.Y[:, ip1] - b.Y[:, ip2])
    venv.close()
    vs, fs = [], []
    for i, n in enumerate(lengths):
        lo, hi = n // 4, 3 * n // 4
        vs.append((X[hi - 1, i] - X[lo, i]) / ((hi - 1 - lo) * dt))
        fs.append(float(np.mean(F[lo:hi, i])))
    return np.array(vs), np.array(fs)


def _net_points(plant: str, v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The virtual test's points and, for a plant with a creep test (:data:`CREEP_SPEEDS`), the
    creep points below them."""
    if plant not in CREEP_SPEEDS:
        return v, f
    vc, fc = creep_points(plant)
    return np.concatenate([np.asarray(v, float), vc]), np.concatenate([np.asarray(f, float), fc])


@functools.cache
def identified_presliding(plant: str) -> tuple[float, float]:
    """``(sigma0, F_b)``: the bristle stiffness [N/m] and breakaway force [N] identified on the
    nominal rig's pre-sliding test (the plant controller module's ``presliding_points``,
    :func:`identification.friction.bristle_stiffness_from_loading`)."""
    from agents.controllers import controller_module
    from identification.friction import bristle_stiffness_from_loading

    mod = controller_module(plant)
    if not hasattr(mod, "presliding_points"):
        raise ValueError(f"plant = {plant!r} has no pre-sliding test")
    return bristle_stiffness_from_loading(*mod.presliding_points())


def _fit_net(kind: str, points: Any, force: Any = None) -> Any:
    """One of 002 sec. 5's nets on the virtual experiment's points: ``"neural"`` the
    feed-forward net (seed 0, 3 restarts), ``"rbf"`` the RBF net (seed 0) with at most half as
    many units as points (50 in the paper): the table and rodless tests give 38-40 points, fewer
    than the 52 that 50 units and a bias need, and a net with as many weights as points
    interpolates the test's noise."""
    from identification.neural import fit_feedforward, fit_rbf

    if kind == "neural":
        return fit_feedforward(points, force, restarts=3, seed=0)
    n = int(np.asarray(force if force is not None else points.v).size)
    return fit_rbf(points, force, n_units=max(2, min(50, n // 2)), seed=0)


class PerCopyFriction:
    """One identified friction model per copy of a batch: ``predict(v)`` with ``v`` of shape
    ``(n,)`` returns ``F_i(v_i)`` [N]."""

    def __init__(self, models: list[Any]) -> None:
        if not models:
            raise ValueError("models must not be empty")
        self.models = list(models)
        self.coulomb_viscous_copies: tuple[int, ...] = ()

    def predict(self, v: Any) -> np.ndarray:
        v = np.asarray(v, dtype=float).reshape(-1)
        if v.size != len(self.models):
            raise ValueError(f"v has {v.size} entries for {len(self.models)} identified models")
        return np.array([float(np.asarray(m.predict(v[i:i + 1])).reshape(-1)[0]) for i, m in enumerate(self.models)])


def identify_on_draws(plant: str, params: list[Any], kind: str = "stribeck") -> PerCopyFriction:
    """The plant's virtual friction experiment run on each parameter set of ``params`` (one plant
    draw per copy) and fitted like :func:`identified_friction`: what a user does on each rig
    before switching the compensator on. Where a draw's test has no point slow enough to
    identify the Stribeck dip (:class:`~identification.friction.data.UnidentifiableError`),
    that copy gets the Coulomb-viscous fit instead (listed in ``coulomb_viscous_copies``). The plant's controller module must accept
    ``friction_points(params)``."""
    from identification.friction import fit_friction

    if kind not in FRICTION_KINDS:
        raise ValueError(f"kind = {kind!r}; allowed {FRICTION_KINDS}")
    experiments = _experiments()
    if plant not in experiments:
        raise ValueError(f"plant = {plant!r}; friction identification available for {sorted(experiments)}")
    from identification.friction.data import UnidentifiableError

    models, fallback = [], []
    for i, p in enumerate(params):
        (v, f), v_eps, model = experiments[plant](p)
        if kind != "stribeck":
            models.append(_fit_net(kind, v, f))
            continue
        try:
            models.append(fit_friction(v, f, model=model, sign_velocity=v_eps))
        except UnidentifiableError:  # no point slow enough to see the dip on this draw
            models.append(fit_friction(v, f, model="coulomb_viscous", sign_velocity=v_eps))
            fallback.append(i)
    out = PerCopyFriction(models)
    out.coulomb_viscous_copies = tuple(fallback)
    return out
