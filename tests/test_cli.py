"""The `hydro` command line, run in-process through `main(argv)`."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from hydro_envs.cli import main
from hydro_envs.data import load_measured

REAL_ENV_ID = "hydro_envs/ServoCylinderPosition-v0"
REPO = Path(__file__).resolve().parents[1]


# --- help / channels ------------------------------------------------------------------


def test_help_lists_subcommands(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "fluid-power" in out
    for cmd in ("channels", "simulate", "validate"):
        assert cmd in out


def test_no_command_prints_help_and_fails(capsys):
    assert main([]) == 2
    assert "channels" in capsys.readouterr().out


def test_subcommand_help(capsys):
    assert main(["simulate", "--help"]) == 0
    out = capsys.readouterr().out
    assert "--steps" in out and "--policy" in out and "--out" in out


def test_help_does_not_import_heavy_modules():
    """`hydro --help` must not pull in gymnasium/numba beyond what `import hydro_envs` does."""
    code = (
        "import sys, io, contextlib\n"
        "import hydro_envs\n"
        "before = set(sys.modules)\n"
        "from hydro_envs.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    rc = main(['--help'])\n"
        "new = set(sys.modules) - before\n"
        "heavy = sorted(m for m in new if m.split('.')[0] in "
        "('gymnasium', 'numba', 'scipy', 'numpy', 'pyarrow'))\n"
        "print(rc, heavy)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "0 []", res.stdout


def test_channels_servo_cylinder_table(capsys):
    assert main(["channels", "servo_cylinder"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    for name, unit in [("t", "[s]"), ("u", "[V]"), ("x", "[m]"), ("p1", "[Pa]"), ("p2", "[Pa]")]:
        row = next(ln for ln in lines if ln.split()[:1] == [name])
        assert row.split()[1] == unit
    # aligned: the unit column starts at the same offset in every row
    rows = [ln for ln in lines if ln.split()[:1] and ln.split()[0] in ("t", "u", "x", "p1", "p2")]
    assert len({ln.index("[") for ln in rows}) == 1


def test_channels_unknown_plant_exit_2(capsys):
    assert main(["channels", "warp_drive"]) == 2
    err = capsys.readouterr().err
    assert "warp_drive" in err and "servo_cylinder" in err


def test_channels_without_plant_lists_plants(capsys):
    assert main(["channels"]) == 0
    assert "servo_cylinder" in capsys.readouterr().out


# --- validate -------------------------------------------------------------------------


@pytest.fixture
def fake_validation(monkeypatch):
    import hydro_envs.validation as validation

    holder = types.SimpleNamespace(rows=[])
    monkeypatch.setattr(validation, "run_validation", lambda: list(holder.rows))
    return holder


def _row(name, published, reproduced, tolerance, unit, source, kind="independent", **kw):
    from hydro_envs.validation import ValidationRow

    return ValidationRow(name, published, reproduced, tolerance, unit, source, kind=kind, **kw)


def _rows_ok():
    return [
        _row("natural frequency", 104.2, 104.9, 0.02, "rad/s", "seed 002, Table 1"),
        _row("Coulomb friction", 310.0, float(np.float64(305.5)), 0.05, "N", "seed 002, Fig. 4",
             kind="consistency"),
    ]


def test_validate_table_all_pass(fake_validation, capsys):
    fake_validation.rows = _rows_ok()
    assert main(["validate"]) == 0
    out = capsys.readouterr().out
    assert "natural frequency" in out and "Coulomb friction" in out and "PASS" in out
    assert "independent rows (1/1 pass)" in out and "consistency rows (1/1 pass)" in out
    assert out.index("independent rows") < out.index("consistency rows")
    assert max(len(line) for line in out.splitlines()) <= 120
    assert out.strip().splitlines()[-1] == "2/2 rows pass (1 independent); validation passed"


def test_validate_table_failure_exit_1(fake_validation, capsys):
    fake_validation.rows = [*_rows_ok(), _row("bulk modulus", 1.4e9, 9e8, 0.1, "Pa", "s")]
    assert main(["validate"]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and out.strip().splitlines()[-1] == "2/3 rows pass (2 independent); validation FAILED"


def test_validate_upper_bound_shown_as_bound(fake_validation, capsys):
    fake_validation.rows = [_row("ratio", 1.0, 0.4, 0.0, "1", "s", upper_bound=True)]
    assert main(["validate"]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("ratio"))
    assert "< 1" in line and "PASS" in line


def test_validate_json(fake_validation, capsys):
    fake_validation.rows = _rows_ok()
    assert main(["validate", "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["passed"] is True and payload["independent"] == 1
    assert [r["name"] for r in payload["rows"]] == ["natural frequency", "Coulomb friction"]
    r = payload["rows"][1]
    assert r["reproduced"] == 305.5 and r["passed"] is True and r["unit"] == "N" and r["kind"] == "consistency"


def test_validate_json_failure(fake_validation, capsys):
    fake_validation.rows = [_row("x", 1.0, float("nan"), 0.1, "m", "s")]
    assert main(["validate", "--json"]) == 1
    payload = json.loads(capsys.readouterr().out)  # strict JSON: NaN became null
    assert payload["passed"] is False
    assert payload["rows"][0]["reproduced"] is None and payload["rows"][0]["passed"] is False


def test_validate_markdown(fake_validation, tmp_path, capsys):
    fake_validation.rows = [*_rows_ok(), _row("bulk | modulus", 1.4e9, 9e8, 0.1, "Pa", "src")]
    out = tmp_path / "docs" / "validation.md"
    assert main(["validate", "--markdown", str(out)]) == 1
    text = out.read_text()
    assert "## Independent rows" in text and "## Consistency rows" in text
    assert "bulk \\| modulus" in text and "| FAIL | src |" in text and "seed 002, Fig. 4" in text


def test_validate_no_rows_is_failure(fake_validation, capsys):
    fake_validation.rows = []
    assert main(["validate"]) == 1
    assert "no validation checks" in capsys.readouterr().out


def test_validation_row_needs_a_kind():
    from hydro_envs.validation import ValidationRow

    with pytest.raises(ValueError, match="kind"):
        ValidationRow("x", 1.0, 1.0, 0.1, "m", "s")
    with pytest.raises(ValueError, match="kind"):
        ValidationRow("x", 1.0, 1.0, 0.1, "m", "s", kind="report")


# --- simulate with a test-local env (not part of the package) ---------------------------


class _FakeServoEnv:
    """Minimal env with the attributes `hydro simulate` relies on."""

    def __new__(cls, *a, **kw):  # build lazily so gymnasium is imported only here
        import gymnasium as gym
        from gymnasium import spaces

        class Env(gym.Env):
            metadata = {"render_modes": []}

            def __init__(self, end_at=None, nan_at=None, randomize=True):
                from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams

                self.params = ServoCylinderParams()
                self.randomize = randomize
                self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
                self.observation_space = spaces.Box(-np.inf, np.inf, shape=(2,),
                                                    dtype=np.float64)
                self.dt = 0.002
                self.plant_name = "servo_cylinder"
                self.end_at, self.nan_at = end_at, nan_at

            def reset(self, *, seed=None, options=None):
                super().reset(seed=seed)
                self.k, self.u = 0, 0.0
                self.x = 0.05 + 0.01 * self.np_random.uniform()
                return np.array([self.x, 0.0]), {}

            def channel_values(self):
                bad = self.nan_at is not None and self.k >= self.nan_at
                return {"u": self.u, "x": float("nan") if bad else self.x,
                        "p1": 5e6 + 1e5 * self.u, "p2": 5e6 - 1e5 * self.u}

            def step(self, action):
                self.k += 1
                self.u = float(np.asarray(action).reshape(-1)[0])
                self.x += 1e-4 * self.u * self.dt
                term = self.end_at is not None and self.k >= self.end_at
                return np.array([self.x, 0.0]), 0.0, term, False, {}

        return Env(*a, **kw)


@pytest.fixture
def fake_env_ids():
    import gymnasium as gym

    ids = {"plain": "hydro_test/FakeServo-v0", "ends": "hydro_test/FakeServoEnds-v0",
           "nan": "hydro_test/FakeServoNaN-v0"}
    gym.register(ids["plain"], entry_point=_FakeServoEnv)
    gym.register(ids["ends"], entry_point=_FakeServoEnv, kwargs={"end_at": 5})
    gym.register(ids["nan"], entry_point=_FakeServoEnv, kwargs={"nan_at": 3})
    yield ids
    for i in ids.values():
        gym.registry.pop(i, None)


def test_simulate_zero_policy(fake_env_ids, tmp_path, capsys):
    out = tmp_path / "run.csv"
    rc = main(["simulate", fake_env_ids["plain"], "--steps", "20", "--policy", "zero",
               "--seed", "3", "--out", str(out)])
    assert rc == 0
    summary = capsys.readouterr().out.strip()
    assert "21 rows" in summary and str(out) in summary and len(summary.splitlines()) == 1
    d = load_measured(out)
    assert d.plant == "servo_cylinder" and len(d) == 21
    np.testing.assert_allclose(d.t, np.arange(21) * 0.002, rtol=0, atol=0)
    assert np.all(d["u"] == 0.0)
    assert d.metadata["env_id"] == fake_env_ids["plain"]
    assert d.metadata["seed"] == "3" and d.metadata["policy"] == "zero"
    assert d.metadata["param.coulomb_friction"].endswith("[N]")


@pytest.mark.parametrize("policy", ["random", "prbs", "multisine", "chirp"])
def test_simulate_row_k_holds_the_input_applied_after_t_k(fake_env_ids, tmp_path, capsys, policy):
    """Sample-and-hold convention: the fake plant integrates x += 1e-4 u dt, so
    x[k+1] - x[k] = 1e-4 dt u[k] with u[k] on row k (and the first row's u the first input)."""
    out = tmp_path / "run.csv"
    assert main(["simulate", fake_env_ids["plain"], "--steps", "200", "--policy", policy,
                 "--seed", "1", "--out", str(out)]) == 0
    capsys.readouterr()
    d = load_measured(out)
    np.testing.assert_allclose(np.diff(d["x"]), 1e-4 * 0.002 * d["u"][:-1], rtol=1e-6, atol=1e-16)
    assert (d["u"][0] != 0.0 or policy == "chirp") and d["u"][-1] == d["u"][-2]
    assert np.max(np.abs(d["u"])) <= 0.5 + 1e-6 and np.ptp(d["u"]) > 0.3


def test_simulate_bad_band_is_an_error(fake_env_ids, tmp_path, capsys):
    rc = main(["simulate", fake_env_ids["plain"], "--steps", "50", "--policy", "chirp", "--f0", "10",
               "--f1", "1000", "--out", str(tmp_path / "x.csv")])
    assert rc == 1 and "Nyquist" in capsys.readouterr().err


def test_simulate_random_policy_is_seeded(fake_env_ids, tmp_path, capsys):
    paths = []
    for name in ("a.csv", "b.csv"):
        p = tmp_path / name
        assert main(["simulate", fake_env_ids["plain"], "--steps", "30", "--policy", "random",
                     "--seed", "7", "--out", str(p)]) == 0
        paths.append(p)
    a, b = (load_measured(p) for p in paths)
    assert np.array_equal(a.to_array(), b.to_array())
    assert np.any(a["u"] != 0.0) and np.all(np.abs(a["u"]) <= 0.5)
    capsys.readouterr()


def test_simulate_stops_when_episode_ends(fake_env_ids, tmp_path, capsys):
    out = tmp_path / "short.csv"
    assert main(["simulate", fake_env_ids["ends"], "--steps", "50", "--out", str(out)]) == 0
    cap = capsys.readouterr()
    assert "terminated after 5 of 50 steps" in cap.err
    assert len(load_measured(out)) == 6


def test_simulate_non_finite_channel_fails_cleanly(fake_env_ids, tmp_path, capsys):
    out = tmp_path / "nan.csv"
    assert main(["simulate", fake_env_ids["nan"], "--steps", "10", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "'x'" in err and "not finite" in err
    assert not out.exists()


def test_simulate_unknown_env_exit_2(tmp_path, capsys):
    pytest.importorskip("gymnasium")
    rc = main(["simulate", "hydro_envs/NoSuchEnv-v0", "--steps", "3",
               "--out", str(tmp_path / "x.csv")])
    assert rc == 2
    assert "NoSuchEnv" in capsys.readouterr().err


def test_simulate_rejects_bad_steps(tmp_path, capsys):
    assert main(["simulate", "x", "--steps", "0", "--out", str(tmp_path / "x.csv")]) == 2
    assert "--steps" in capsys.readouterr().err


# --- simulate with the real env (skipped until it is registered) ------------------------


@pytest.fixture
def real_env_id():
    gym = pytest.importorskip("gymnasium")
    try:
        import hydro_envs  # noqa: F401
    except ImportError as e:  # package still being assembled
        pytest.skip(f"hydro_envs does not import yet: {e}")
    try:
        env = gym.make(REAL_ENV_ID)
    except gym.error.Error as e:  # NameNotFound / NamespaceNotFound / VersionNotFound
        pytest.skip(f"{REAL_ENV_ID} not registered yet: {e}")
    env.close()
    return REAL_ENV_ID


@pytest.mark.parametrize("policy", ["zero", "random", "prbs"])
def test_simulate_real_env(real_env_id, tmp_path, capsys, policy):
    out = tmp_path / f"servo_{policy}.csv"
    rc = main(["simulate", real_env_id, "--steps", "2500", "--policy", policy, "--seed", "0",
               "--nominal", "--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    d = load_measured(out)
    assert d.plant == "servo_cylinder"
    assert len(d) == 2501  # longer than one 2000-step episode
    assert d.names == ("u", "x", "p1", "p2")
    assert np.all(d["p1"] > 0) and np.all(d["p2"] > 0)  # absolute pressures
    assert d.metadata["randomized"] == "False"
    from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams

    nominal = ServoCylinderParams()
    assert d.metadata["param.coulomb_friction"] == f"{nominal.coulomb_friction!r} [N]"
