"""Loading a policy folder never unpickles by default (agents.policies, hydro benchmark)."""

from __future__ import annotations

import base64
import json
import pickle
import zipfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("torch")

from agents import benchmark as bm  # noqa: E402
from agents import benchmark_cli  # noqa: E402
from agents.policies import (  # noqa: E402
    ARGS_FILE,
    CONFIG_FILE,
    MODEL_FILE,
    OBS_NORM_FILE,
    POLICY_FILE,
    VECNORM_FILE,
    UntrustedPickleError,
    export_compact,
    load_trained,
)

ENV = "hydro_envs/ServoCylinderPosition-v0"


class _Payload:
    """Unpickling this creates the file ``path``: a stand-in for arbitrary code."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)

    def __reduce__(self):
        return (Path.write_text, (Path(self.path), "pwned"))


def _malicious_run(folder: Path, marker: Path, *, zip_payload: bool = True, pkl_payload: bool = True) -> Path:
    folder.mkdir(parents=True)
    (folder / ARGS_FILE).write_text(json.dumps({"env_id": ENV, "algo": "ppo"}))
    (folder / CONFIG_FILE).write_text(f"{ENV}:\n  policy: MlpPolicy\n")
    blob = base64.b64encode(pickle.dumps(_Payload(marker))).decode()
    data = {"policy_class": {":type:": "<class 'abc.ABCMeta'>", ":serialized:": blob}} if zip_payload else {}
    with zipfile.ZipFile(folder / MODEL_FILE, "w") as z:
        z.writestr("data", json.dumps(data))
    if pkl_payload:
        (folder / VECNORM_FILE).write_bytes(pickle.dumps(_Payload(marker.with_suffix(".pkl"))))
    return folder


def test_pickle_only_folder_is_refused_without_running_the_payload(tmp_path):
    marker = tmp_path / "pwned.txt"
    run = _malicious_run(tmp_path / "run", marker)
    with pytest.raises(UntrustedPickleError) as err:
        load_trained(run)
    msg = str(err.value)
    assert "--trust-pickle" in msg and "execute" in msg and "export_compact" in msg
    with pytest.raises(UntrustedPickleError):
        load_trained(run, which="final", trust_pickle=False)
    with pytest.raises(UntrustedPickleError):
        export_compact(run, tmp_path / "compact")
    assert not marker.exists() and not marker.with_suffix(".pkl").exists()


def test_the_payload_is_live_with_trust_pickle(tmp_path):
    """The check above can fail: with the explicit flag the same folder runs the payload."""
    marker = tmp_path / "pwned.txt"
    run = _malicious_run(tmp_path / "run", marker)
    with pytest.raises(Exception):
        load_trained(run, trust_pickle=True)
    assert marker.exists()


def test_trust_pickle_must_be_a_bool(tmp_path):
    run = _malicious_run(tmp_path / "run", tmp_path / "m.txt")
    with pytest.raises(TypeError, match="trust_pickle"):
        load_trained(run, trust_pickle="yes")
    assert not (tmp_path / "m.txt").exists()


def test_benchmark_cli_refuses_pickle_folders(tmp_path, capsys):
    marker = tmp_path / "pwned.txt"
    run = _malicious_run(tmp_path / "run", marker)
    rc = benchmark_cli.main(["--env", ENV, "--controllers", "pid", "--policy", str(run), "--n", "1", "--steps", "20",
                  "--no-figures"])
    assert rc == 2
    assert "--trust-pickle" in capsys.readouterr().err
    assert not marker.exists() and not marker.with_suffix(".pkl").exists()
    # the config-file form sb3:RUN_DIR goes through the same loader
    with pytest.raises(UntrustedPickleError):
        bm.run_benchmark(ENV, [f"sb3:{run}"], "nominal", n=1, episode_steps=20, figures=False)
    assert not marker.exists()
    # and with --trust-pickle the loader does unpickle (payload runs, then the fake model fails)
    try:
        benchmark_cli.main(["--env", ENV, "--controllers", "pid", "--policy", str(run), "--n", "1", "--steps", "20",
                 "--no-figures", "--trust-pickle"])
    except Exception:  # SB3 then rejects the fake model; the payload has already run
        pass
    assert marker.exists()


@pytest.fixture(scope="module")
def pickle_run(tmp_path_factory) -> Path:
    """A genuine pickle-only run folder (an untrained PPO model and VecNormalize statistics)."""
    import stable_baselines3 as sb3
    from stable_baselines3.common.vec_env import VecNormalize

    from hydro_envs.envs.sb3 import make_sb3_vec_env

    run = tmp_path_factory.mktemp("runs") / "pickled"
    run.mkdir()
    venv = VecNormalize(make_sb3_vec_env(ENV, 2, seed=0), norm_reward=False)
    venv.reset()
    for _ in range(20):  # non-trivial statistics
        venv.step(np.random.default_rng(0).uniform(-1, 1, (2, 1)).astype(np.float32))
    model = sb3.PPO("MlpPolicy", venv, seed=0, n_steps=32, batch_size=32, device="cpu")
    model.save(run / MODEL_FILE)
    venv.save(str(run / VECNORM_FILE))
    (run / ARGS_FILE).write_text(json.dumps({"env_id": ENV, "algo": "ppo"}))
    (run / CONFIG_FILE).write_text(f"{ENV}:\n  policy: MlpPolicy\n")
    return run


def test_trusted_export_gives_the_same_actions_without_pickles(pickle_run, tmp_path):
    with pytest.raises(UntrustedPickleError):
        load_trained(pickle_run)
    compact = export_compact(pickle_run, tmp_path / "compact", trust_pickle=True)
    assert (compact / POLICY_FILE).is_file() and (compact / OBS_NORM_FILE).is_file()
    assert not list(compact.glob("*.pkl")) and not list(compact.glob("*.zip"))
    full, small = load_trained(pickle_run, trust_pickle=True), load_trained(compact)
    obs = np.random.default_rng(1).normal(0.0, 2.0, (200, 11)).astype(np.float32)
    assert np.array_equal(full.predict(obs)[0], small.predict(obs)[0])
    assert np.array_equal(full.normalize(obs), small.normalize(obs))
    # the loaded compact policy exposes model.policy like an SB3 model
    assert set(small.model.policy.state_dict()) == set(full.model.policy.state_dict())


# ---- the statistics: required, checked, bound to their weights (issue 53) ------------------------

PRETRAINED = Path(__file__).resolve().parents[1] / "agents" / "pretrained" / "servo_cylinder" / "ppo_s0"


def _copy(tmp_path, name="run"):
    import shutil

    dst = tmp_path / name
    shutil.copytree(PRETRAINED, dst)
    return dst


def _npz(run, **over):
    with np.load(run / OBS_NORM_FILE) as z:
        vals = {k: z[k] for k in z.files}
    vals.update(over)
    np.savez(run / OBS_NORM_FILE, **vals)


def test_statistics_are_required_when_trained_with_normalisation(tmp_path):
    run = _copy(tmp_path)
    (run / OBS_NORM_FILE).unlink()
    with pytest.raises(ValueError, match=r"obs_normalization\.npz: missing; the policy was trained with observation "
                       "normalisation"):
        load_trained(run)
    cfg = (run / CONFIG_FILE).read_text().replace("norm_obs: true", "norm_obs: false")
    (run / CONFIG_FILE).write_text(cfg)
    assert load_trained(run).obs_normalizer is None  # a run without normalisation needs none


@pytest.mark.parametrize("over,match", [
    ({"mean": np.zeros(1), "var": np.ones(1)}, r"mean has shape \(1,\); allowed \(11,\)"),
    ({"var": np.zeros(11)}, r"var\[0\] = 0; allowed >= 1e-06"),
    ({"mean": np.full(11, np.nan)}, "finite arrays"),
    ({"clip_obs": np.asarray(0.0)}, "clip_obs = 0.0; allowed a finite number > 0"),
    ({"policy_sha256": np.asarray("0" * 64)}, "written with other weights than policy.pt"),
])
def test_bad_statistics_are_refused_naming_the_file(tmp_path, over, match):
    run = _copy(tmp_path)
    _npz(run, **over)
    with pytest.raises(ValueError, match=match) as e:
        load_trained(run)
    assert OBS_NORM_FILE in str(e.value) or "finite arrays" in str(e.value)


def test_bad_weights_and_run_files_are_one_line_errors(tmp_path):
    run = _copy(tmp_path, "pt")
    (run / POLICY_FILE).write_bytes(b"\x80\x04 garbage")
    with pytest.raises(ValueError, match=r"policy\.pt: not a weights file \(UnpicklingError") as e:
        load_trained(run)
    assert "\n" not in str(e.value) and "weights_only set to False" not in str(e.value)
    run = _copy(tmp_path, "args")
    (run / ARGS_FILE).write_text("{")
    with pytest.raises(ValueError, match=r"args\.json: not valid JSON"):
        load_trained(run)
    run = _copy(tmp_path, "cfg")
    (run / CONFIG_FILE).write_text(f"{ENV}:\n  policy: MlpPolicy\n  policy: MlpPolicy\n")
    with pytest.raises(ValueError, match="duplicate key 'policy'"):
        load_trained(run)


def test_weights_and_statistics_are_written_as_one_unit(tmp_path, monkeypatch):
    import errno
    import hashlib

    from agents import policies

    pol = load_trained(PRETRAINED)
    dest = tmp_path / "dest"
    policies.write_compact(pol.model.policy, pol.obs_normalizer, dest)
    assert sorted(p.name for p in dest.iterdir()) == [OBS_NORM_FILE, POLICY_FILE]
    with np.load(dest / OBS_NORM_FILE) as z:
        assert str(z["policy_sha256"]) == hashlib.sha256((dest / POLICY_FILE).read_bytes()).hexdigest()
    before = {p.name: p.read_bytes() for p in dest.iterdir()}

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(policies.ObsNormalizer, "_write", full)
    with pytest.raises(OSError, match=rf"cannot write {dest / OBS_NORM_FILE}: No space left"):
        policies.write_compact(pol.model.policy, pol.obs_normalizer, dest)
    assert {p.name: p.read_bytes() for p in dest.iterdir()} == before  # the old pair, untouched, no temp folder
    fresh = tmp_path / "fresh"
    with pytest.raises(OSError):
        policies.write_compact(pol.model.policy, pol.obs_normalizer, fresh)
    assert list(fresh.iterdir()) == []  # no policy.pt without its statistics
    monkeypatch.undo()
    # a torn pair (new weights beside older statistics) is refused on loading
    other = _copy(tmp_path, "torn")
    policies.write_compact(pol.model.policy, pol.obs_normalizer, other)
    state = __import__("torch").load(other / POLICY_FILE, weights_only=True)
    state[next(iter(state))] = state[next(iter(state))] + 1.0
    __import__("torch").save(state, other / POLICY_FILE)
    with pytest.raises(ValueError, match="written with other weights"):
        load_trained(other)
