"""Neural friction models of 002 sec. 5 on the virtual constant-velocity experiment.

002 sec. 5 reports the training error E (eq (11)) of a 10-neuron feed-forward net (3.0787 N)
and a 50-neuron RBF net (2.4838 N) on its rig. Ours are computed on the points of the virtual
150 s experiment (nominal plant, 0.03 mm encoder, 20 kPa pressure noise filtered at 50 Hz):
E ~ 0.9 N (FF) and ~0.7 N (RBF); the truth (the plant's friction law) bounds what a good net
can do, and the nets must reproduce it where the plant slides steadily.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.data.sensors import SensorModel
from hydro_envs.plants.servo_cylinder.friction_test import run_friction_experiment
from identification.constant_velocity import friction_points_from_square_wave
from identification.friction import (
    InsufficientDataError,
    fit_friction,
    mean_absolute_error,
    static_friction,
)
from identification.neural import (
    PAPER_E,
    cross_validated_error,
    fit_feedforward,
    fit_rbf,
    torch_module_from_state_dict,
)

REPO = Path(__file__).resolve().parents[1]
NOMINAL = ServoCylinderParams()
TRUTH = {"F_c": NOMINAL.coulomb_friction, "F_s": NOMINAL.static_friction,
         "v_s": NOMINAL.stribeck_velocity, "F_v": NOMINAL.viscous_friction}


@pytest.fixture(scope="module")
def points():
    run = run_friction_experiment(sensors=SensorModel.realistic(), seed=0)
    return friction_points_from_square_wave(run.data)


@pytest.fixture(scope="module")
def nets(points):
    return fit_feedforward(points, seed=0), fit_rbf(points, seed=0)


def test_paper_error_E_on_virtual_experiment(points, nets):
    """E (eq (11)) of both nets on the 136 measured points. Both are at the level of the
    points' own scatter (a 4-parameter Stribeck fit gets ~1.0 N), below the paper's 3.08 / 2.48
    N: our points are averages of long noise-only windows of a plant whose friction *is* a
    Stribeck curve, the rig's carried seal hysteresis, position dependence and thermal drift."""
    ff, rbf = nets
    stribeck = fit_friction(points, model="stribeck", sigma=points.force_std / np.sqrt(points.n_samples))
    e_s = stribeck.metrics["E"]
    assert ff.metrics["E"] == pytest.approx(mean_absolute_error(points.force, ff.predict(points.v)))
    assert 0.3 < ff.metrics["E"] < 1.2 * e_s
    assert 0.3 < rbf.metrics["E"] < 1.2 * e_s
    assert ff.metrics["E"] < PAPER_E["feedforward"] and rbf.metrics["E"] < PAPER_E["rbf"]
    assert ff.n_weights == 31 and rbf.n_units == 50
    assert ff.info["trainer"] == "least_squares(method='lm')"


def test_nets_follow_the_true_friction_where_sliding_is_steady(points, nets):
    """Against the plant's friction law (the truth) on 25-200 mm/s, where the plant slides
    steadily: mean absolute error below 1.5 N for both nets (the curve spans 47-100 N)."""
    ff, rbf = nets
    s = np.linspace(0.025, 0.2, 200)
    v = np.concatenate([s, -s])
    truth = static_friction("stribeck", v, TRUTH)
    assert mean_absolute_error(truth, ff.predict(v)) < 1.5
    assert mean_absolute_error(truth, rbf.predict(v)) < 1.5


def test_held_out_error_is_reported(points):
    cv = cross_validated_error(points, kind="rbf", folds=4)
    assert cv["folds"] == 4 and 0.5 < cv["E"] < 6.0


def test_numba_numpy_and_torch_agree(nets):
    torch = pytest.importorskip("torch")
    v = np.linspace(-0.3, 0.3, 2001)
    for model in nets:
        a = model.predict(v)
        b = model.predict_numba(v)
        m = model.to_torch()
        with torch.no_grad():
            c = m(torch.as_tensor(v)).numpy()
        np.testing.assert_allclose(b, a, atol=1e-9, rtol=0)
        np.testing.assert_allclose(c, b, atol=1e-6, rtol=0)
        # any input shape, float32 export close too
        with torch.no_grad():
            c2 = m(torch.as_tensor(v.reshape(-1, 1, 1))).numpy().ravel()
            c32 = model.to_torch(torch.float32)(torch.as_tensor(v, dtype=torch.float32)).numpy()
        np.testing.assert_allclose(c2, b, atol=1e-6, rtol=0)
        np.testing.assert_allclose(c32, b, atol=1e-3 * np.max(np.abs(b)), rtol=0)


def test_torch_state_dict_loads_with_weights_only(nets, tmp_path):
    torch = pytest.importorskip("torch")
    v = torch.linspace(-0.25, 0.25, 501, dtype=torch.float64)
    for model in nets:
        m = model.to_torch()
        path = tmp_path / f"{model.kind}.pt"
        torch.save(m.state_dict(), path)
        sd = torch.load(path, weights_only=True)
        m2 = torch_module_from_state_dict(sd)
        with torch.no_grad():
            assert torch.equal(m2(v), m(v))
    with pytest.raises(ValueError, match="friction-net"):
        torch_module_from_state_dict({"foo": torch.zeros(1)})


def test_neural_module_works_without_torch():
    """numpy/numba parts import and run with torch unavailable; only to_torch needs it."""
    code = (
        "import sys, importlib.abc\n"
        "class Block(importlib.abc.MetaPathFinder):\n"  # `import torch` raises ImportError
        "    def find_spec(self, name, path, target=None):\n"
        "        if name.split('.')[0] == 'torch':\n"
        "            raise ImportError('torch blocked')\n"
        "sys.meta_path.insert(0, Block())\n"
        "import numpy as np\n"
        "from identification.neural import fit_feedforward, fit_rbf\n"
        "v = np.linspace(-0.2, 0.2, 60); f = 40*np.sign(v) + 250*v\n"
        "m = fit_rbf(v, f, n_units=10); ff = fit_feedforward(v, f, restarts=1, max_nfev=50)\n"
        "assert np.allclose(m.predict_numba(v), m.predict(v))\n"
        "try:\n"
        "    m.to_torch()\n"
        "except ImportError:\n"
        "    print('ok')\n"
        "assert 'torch' not in sys.modules\n"
    )
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "ok"


def test_reproducible_and_data_checks(points):
    a = fit_rbf(points, seed=3)
    b = fit_rbf(points, seed=3)
    np.testing.assert_array_equal(a.weights, b.weights)
    f1 = fit_feedforward(points.v[:60], points.force[:60], seed=1, restarts=1, max_nfev=100)
    f2 = fit_feedforward(points.v[:60], points.force[:60], seed=1, restarts=1, max_nfev=100)
    np.testing.assert_allclose(f1.w1, f2.w1, rtol=1e-6)  # BLAS summation order may differ
    with pytest.raises(InsufficientDataError, match="31 weights"):
        fit_feedforward(points.v[:20], points.force[:20])
    with pytest.raises(InsufficientDataError, match="50 units"):
        fit_rbf(points.v[:30], points.force[:30])
    with pytest.raises(ValueError, match="finite"):
        fit_rbf(np.array([0.1, np.nan]), np.array([1.0, 2.0]))


def test_buffer_roundtrip_in_memory(nets):
    torch = pytest.importorskip("torch")
    ff, _ = nets
    buf = io.BytesIO()
    torch.save(ff.to_torch().state_dict(), buf)
    buf.seek(0)
    m = torch_module_from_state_dict(torch.load(buf, weights_only=True))
    assert m.hidden.weight.shape == (10, 1)
