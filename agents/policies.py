"""Trained SB3 agents as policy objects for evaluation and benchmarking.

:func:`load_trained` opens a run folder written by :func:`agents.train.train` and returns a
:class:`TrainedPolicy` with the SB3-style ``predict(obs, state=None, episode_start=None,
deterministic=True) -> (action, state)`` that the classical controllers of
:mod:`agents.controllers` also expose. It applies the run's *frozen* ``VecNormalize``
observation normalisation (the statistics saved at the end of training, or with the best
evaluation for ``which="best"``) and then the model, so callers pass raw env observations.

Run-folder layout (names are the constants below)::

    config.yml          resolved hyperparameters, rl-zoo format keyed by the env id
    args.json           the arguments of the run (env id, algo, seed, randomisation, eval set)
    model.zip           final SB3 model            vecnormalize.pkl       its statistics
    best_model.zip      best evaluated model       best_vecnormalize.pkl  its statistics
    evaluations.csv/npz periodic evaluation log    tb/                    TensorBoard logs

The model is read with SB3's ``load`` (its tensors with ``torch.load(weights_only=True)``).
``vecnormalize.pkl`` is SB3's own pickle format: load run folders you trust, as with any pickle.
"""

from __future__ import annotations

import json
import pickle
from pathlib import Path
from typing import Any

import numpy as np
import yaml

__all__ = [
    "ALGOS",
    "MODEL_FILE",
    "VECNORM_FILE",
    "BEST_MODEL_FILE",
    "BEST_VECNORM_FILE",
    "CONFIG_FILE",
    "ARGS_FILE",
    "EVAL_CSV",
    "EVAL_NPZ",
    "TB_DIR",
    "TrainedPolicy",
    "algo_class",
    "load_trained",
]

ALGOS = ("ppo", "sac", "td3")
MODEL_FILE = "model.zip"
VECNORM_FILE = "vecnormalize.pkl"
BEST_MODEL_FILE = "best_model.zip"
BEST_VECNORM_FILE = "best_vecnormalize.pkl"
CONFIG_FILE = "config.yml"
ARGS_FILE = "args.json"
EVAL_CSV = "evaluations.csv"
EVAL_NPZ = "evaluations.npz"
TB_DIR = "tb"


def algo_class(algo: str) -> type:
    """The SB3 algorithm class of ``algo`` (one of :data:`ALGOS`)."""
    import stable_baselines3 as sb3

    classes = {"ppo": sb3.PPO, "sac": sb3.SAC, "td3": sb3.TD3}
    if algo not in classes:
        raise ValueError(f"algo = {algo!r}; allowed {ALGOS}")
    return classes[algo]


class TrainedPolicy:
    """An SB3 model behind its frozen observation normalisation.

    ``obs_normalizer`` is the unpickled ``VecNormalize`` of the run (no venv attached; only
    its ``normalize_obs`` is used, which never updates the statistics) or ``None`` when the
    run did not normalise observations.
    """

    def __init__(self, model: Any, obs_normalizer: Any | None, *, env_id: str = "", algo: str = "",
                 config: dict[str, Any] | None = None, run_dir: Path | None = None) -> None:
        self.model = model
        self.obs_normalizer = obs_normalizer
        if obs_normalizer is not None:
            obs_normalizer.training = False
            obs_normalizer.norm_reward = False
        self.env_id = env_id
        self.algo = algo
        self.config = dict(config or {})
        self.run_dir = run_dir
        self.observation_space = model.observation_space
        self.action_space = model.action_space

    def normalize(self, obs: Any) -> np.ndarray:
        """Raw observations -> the normalised observations the model was trained on."""
        o = np.asarray(obs, dtype=np.float32)
        if self.obs_normalizer is None or not self.obs_normalizer.norm_obs:
            return o
        return np.asarray(self.obs_normalizer.normalize_obs(o), dtype=np.float32)

    def predict(self, obs: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True):
        """SB3-style ``predict`` on raw observations ``(obs_dim,)`` or ``(n, obs_dim)``.

        Returns ``(action, state)``; actions lie in the env's action space (SB3 clips the
        policy output to the Box bounds). The MLP policies are stateless, so ``state`` and
        ``episode_start`` are passed through to the model unchanged.
        """
        o = np.asarray(obs, dtype=np.float32)
        shape = self.observation_space.shape
        if o.shape != shape and (o.ndim != len(shape) + 1 or o.shape[1:] != shape):
            raise ValueError(f"obs must have shape {shape} or (n, *{shape}), got {o.shape}")
        if not np.all(np.isfinite(o)):
            raise ValueError("obs must be finite (NaN or inf given)")
        return self.model.predict(self.normalize(o), state=state, episode_start=episode_start,
                                  deterministic=deterministic)


def load_trained(run_dir: str | Path, which: str = "final", device: str = "cpu") -> TrainedPolicy:
    """Load the ``which`` (``"final"`` or ``"best"``) model of a run folder with its frozen
    ``VecNormalize`` observation statistics."""
    run = Path(run_dir)
    if which not in ("final", "best"):
        raise ValueError(f"which = {which!r}; allowed ('final', 'best')")
    model_file, vn_file = (MODEL_FILE, VECNORM_FILE) if which == "final" else (BEST_MODEL_FILE, BEST_VECNORM_FILE)
    for f in (ARGS_FILE, CONFIG_FILE, model_file):
        if not (run / f).is_file():
            raise FileNotFoundError(f"{run / f} not found: not a finished run folder of agents.train")
    args = json.loads((run / ARGS_FILE).read_text())
    config_all = yaml.safe_load((run / CONFIG_FILE).read_text())
    env_id, algo = args["env_id"], args["algo"]
    model = algo_class(algo).load(run / model_file, device=device)
    normalizer = None
    if (run / vn_file).is_file():
        with open(run / vn_file, "rb") as fh:
            normalizer = pickle.load(fh)  # SB3 VecNormalize state (venv excluded)
    return TrainedPolicy(model, normalizer, env_id=env_id, algo=algo,
                         config=config_all.get(env_id, {}), run_dir=run)
