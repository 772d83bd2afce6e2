r"""Neural friction models of 002 sec. 5: a feed-forward net (one hidden layer, 10 tanh
neurons, Levenberg-Marquardt) and a radial-basis-function net (50 Gaussian units).

002 sec. 5: "The inputs of the neural networks are the velocity of the actuator, the training
set is given by the measurement points" (the constant-velocity points of sec. 4). The
feed-forward net was MATLAB's ``newff`` with 10 hidden neurons and one output neuron, trained
by Levenberg-Marquardt on the mean squared error; the RBF net ``newrb`` with 50 neurons. The
fitting error is eq (11), ``E = (1/N) sum |F_f(v_i) - F_NN(v_i)|`` (mean absolute error over
the training points): 3.0787 N (feed-forward) and 2.4838 N (RBF) on the paper's rig.

Here (``docs/references.md``, numerics notes):

* :func:`fit_feedforward` -- ``F = f_s (b2 + sum_j W2_j tanh(W1_j v / v_s + b1_j))`` with
  input/output scales ``v_s = max |v|``, ``f_s = max |F|``; the 31 weights are trained by
  ``scipy.optimize.least_squares(method="lm")`` (MINPACK Levenberg-Marquardt) on the
  residuals, from Nguyen-Widrow initial weights (``newff``'s default) drawn from
  ``numpy.random.default_rng(seed)``; the best of ``restarts`` starts is kept.
* :func:`fit_rbf` -- ``F = f_s (b + sum_j w_j exp(-((v / v_s - c_j) / s_j)^2))``: centres
  ``c_j`` by k-means (``scipy.cluster.vq.kmeans2``, k-means++ start, seeded) run separately on
  each direction's points (units shared in proportion to the points: friction jumps at
  ``v = 0``, and a plain k-means merges the slowest point of each direction into one centre
  at ``v = 0``, which ruins the fit there), widths from the centre spacing
  (``s_j = width_factor *`` mean distance of centre j to its two nearest same-side
  neighbours, capped at ``|c_j| / 2`` so that no unit reaches across the jump at ``v = 0``),
  output weights and bias by linear least squares (``numpy.linalg.lstsq``).
  (``newrb`` instead adds neurons one by one at the worst-fitted point with a fixed spread;
  k-means centres are the common alternative and need no spread tuning.)

Both models evaluate with numpy (:meth:`predict`) and compiled numba kernels
(:meth:`predict_numba`), and export as a ``torch.nn.Module`` (:meth:`to_torch`; torch is
imported only there) whose ``state_dict`` holds tensors only, so ``torch.load(...,
weights_only=True)`` reads it and :func:`torch_module_from_state_dict` rebuilds the module.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numba as nb
import numpy as np
from scipy import optimize
from scipy.cluster.vq import kmeans2

from identification.friction import (
    FrictionPoints,
    InsufficientDataError,
    mean_absolute_error,
    nrmse,
    rmse,
)

__all__ = [
    "FeedForwardFriction",
    "RBFFriction",
    "fit_feedforward",
    "fit_rbf",
    "fit_neural_friction",
    "cross_validated_error",
    "torch_module_classes",
    "torch_module_from_state_dict",
    "PAPER_E",
]

#: 002 sec. 5, eq (11) values reported on the paper's rig [N]
PAPER_E = {"feedforward": 3.0787, "rbf": 2.4838}


# ======================================================================================
# compiled evaluation
# ======================================================================================


@nb.njit(cache=True, error_model="numpy")
def _ff_eval(v, w1, b1, w2, b2, v_scale, f_scale, out):
    for i in range(v.shape[0]):
        z = v[i] / v_scale
        acc = b2
        for j in range(w1.shape[0]):
            acc += w2[j] * math.tanh(w1[j] * z + b1[j])
        out[i] = f_scale * acc
    return out


@nb.njit(cache=True, error_model="numpy")
def _rbf_eval(v, centres, widths, weights, bias, v_scale, f_scale, out):
    for i in range(v.shape[0]):
        z = v[i] / v_scale
        acc = bias
        for j in range(centres.shape[0]):
            r = (z - centres[j]) / widths[j]
            acc += weights[j] * math.exp(-r * r)
        out[i] = f_scale * acc
    return out


def _metrics(y, y_hat) -> dict[str, float]:
    return {"E": mean_absolute_error(y, y_hat), "rmse": rmse(y, y_hat), "nrmse": nrmse(y, y_hat),
            "n_points": int(np.size(y))}


def _xy(points, force) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(points, FrictionPoints):
        if force is not None:
            raise TypeError("pass either FrictionPoints or (v, force)")
        v, f = points.v, points.force
    else:
        if force is None:
            raise TypeError("force is required with a velocity array")
        v = np.asarray(points, dtype=float).ravel()
        f = np.asarray(force, dtype=float).ravel()
    if v.shape != f.shape:
        raise ValueError(f"v and force differ in length: {v.shape} vs {f.shape}")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(f))):
        raise ValueError("v and force must be finite")
    return v, f


# ======================================================================================
# feed-forward net
# ======================================================================================


@dataclass
class FeedForwardFriction:
    """One-hidden-layer tanh net ``v -> F`` (see module docstring); arrays in float64."""

    w1: np.ndarray
    b1: np.ndarray
    w2: np.ndarray
    b2: float
    v_scale: float
    f_scale: float
    metrics: dict[str, float] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

    kind = "feedforward"

    @property
    def n_hidden(self) -> int:
        return int(self.w1.size)

    @property
    def n_weights(self) -> int:
        return 3 * self.n_hidden + 1

    def predict(self, v: Any) -> np.ndarray:
        """Friction force [N] at velocities ``v`` [m/s] (numpy)."""
        v = np.asarray(v, dtype=float)
        z = v[..., None] / self.v_scale
        return self.f_scale * (self.b2 + _dot_last(np.tanh(z * self.w1 + self.b1), self.w2))

    __call__ = predict

    def predict_numba(self, v: Any) -> np.ndarray:
        """Same as :meth:`predict` through a compiled kernel (1-D input)."""
        v = np.ascontiguousarray(np.asarray(v, dtype=float).ravel())
        return _ff_eval(v, self.w1, self.b1, self.w2, float(self.b2), float(self.v_scale),
                        float(self.f_scale), np.empty_like(v))

    def to_torch(self, dtype: Any = None):
        """A ``torch.nn.Module`` computing the same function (default dtype float64)."""
        import torch

        ff_cls, _ = torch_module_classes()
        dtype = torch.float64 if dtype is None else dtype
        m = ff_cls(self.n_hidden).to(dtype)
        with torch.no_grad():
            m.hidden.weight.copy_(torch.as_tensor(self.w1.reshape(-1, 1), dtype=dtype))
            m.hidden.bias.copy_(torch.as_tensor(self.b1, dtype=dtype))
            m.out.weight.copy_(torch.as_tensor(self.w2.reshape(1, -1), dtype=dtype))
            m.out.bias.copy_(torch.as_tensor([self.b2], dtype=dtype))
            m.v_scale.fill_(self.v_scale)
            m.f_scale.fill_(self.f_scale)
        return m

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "w1": self.w1.tolist(), "b1": self.b1.tolist(),
                "w2": self.w2.tolist(), "b2": self.b2, "v_scale": self.v_scale,
                "f_scale": self.f_scale, "metrics": dict(self.metrics)}


def _dot_last(a: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``a @ w`` over the last axis as numpy's own sum: the same bits on every run (a threaded
    BLAS product may sum in a load-dependent order, and a fit or a closed loop amplifies that)."""
    return (a * w).sum(axis=-1)


def _nguyen_widrow(rng: np.random.Generator, n_hidden: int) -> np.ndarray:
    """Nguyen-Widrow start for one input in [-1, 1] (MATLAB ``initnw``), output weights small."""
    mag = 0.7 * n_hidden  # 0.7 H^(1/n_in), n_in = 1
    w1 = mag * rng.choice([-1.0, 1.0], n_hidden) * rng.uniform(0.5, 1.0, n_hidden)
    b1 = mag * np.linspace(-1.0, 1.0, n_hidden) * np.sign(w1) * rng.uniform(0.8, 1.0, n_hidden)
    w2 = rng.uniform(-0.5, 0.5, n_hidden)
    b2 = rng.uniform(-0.5, 0.5)
    return np.concatenate([w1, b1, w2, [b2]])


def fit_feedforward(
    points: FrictionPoints | Any,
    force: Any = None,
    *,
    n_hidden: int = 10,
    seed: int | None = 0,
    restarts: int = 5,
    max_nfev: int = 500,
) -> FeedForwardFriction:
    """Train the 002 sec. 5 feed-forward net by Levenberg-Marquardt (``least_squares(method="lm")``).

    ``restarts`` Nguyen-Widrow starts from ``default_rng(seed)``; the lowest training MSE wins
    (MATLAB users retrain ``newff`` the same way). Each start runs at most ``max_nfev``
    evaluations (MATLAB ``trainlm`` stops after 1000 epochs): the net keeps sharpening its step
    at ``v = 0`` and LM creeps on, 500 changes E by < 3 % against 3000 at 1/6 of the time. Needs more points than weights
    (``3 n_hidden + 1``; MINPACK's LM requires it).
    """
    v, f = _xy(points, force)
    h = int(n_hidden)
    if h < 1:
        raise ValueError(f"n_hidden must be >= 1, got {n_hidden}")
    n_w = 3 * h + 1
    if v.size <= n_w:
        raise InsufficientDataError(
            f"the feed-forward net has {n_w} weights and needs more points than that; got {v.size}"
        )
    v_scale = float(np.max(np.abs(v))) or 1.0
    f_scale = float(np.max(np.abs(f))) or 1.0
    z = v / v_scale
    y = f / f_scale

    def unpack(w):
        return w[:h], w[h:2 * h], w[2 * h:3 * h], w[3 * h]

    def resid(w):
        w1, b1, w2, b2 = unpack(w)
        return b2 + _dot_last(np.tanh(np.outer(z, w1) + b1), w2) - y

    def jac(w):
        w1, b1, w2, _ = unpack(w)
        a = np.tanh(np.outer(z, w1) + b1)
        d = (1.0 - a * a) * w2  # d out / d pre-activation
        return np.column_stack([d * z[:, None], d, a, np.ones(z.size)])

    rng = np.random.default_rng(seed)
    best = None
    for _ in range(max(1, int(restarts))):
        w0 = _nguyen_widrow(rng, h)
        sol = optimize.least_squares(resid, w0, jac=jac, method="lm", max_nfev=max_nfev,
                                     xtol=1e-12, ftol=1e-12, gtol=1e-12)
        cost = float(np.mean(sol.fun**2))
        if best is None or cost < best[0]:
            best = (cost, sol)
    w1, b1, w2, b2 = unpack(best[1].x)
    model = FeedForwardFriction(w1.copy(), b1.copy(), w2.copy(), float(b2), v_scale, f_scale)
    model.metrics = _metrics(f, model.predict(v))
    model.info = {"mse_scaled": best[0], "nfev": int(best[1].nfev), "restarts": int(restarts),
                  "seed": seed, "trainer": "least_squares(method='lm')"}
    return model


# ======================================================================================
# RBF net
# ======================================================================================


@dataclass
class RBFFriction:
    """Gaussian RBF net ``v -> F`` (see module docstring)."""

    centres: np.ndarray
    widths: np.ndarray
    weights: np.ndarray
    bias: float
    v_scale: float
    f_scale: float
    metrics: dict[str, float] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

    kind = "rbf"

    @property
    def n_units(self) -> int:
        return int(self.centres.size)

    def predict(self, v: Any) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        r = (v[..., None] / self.v_scale - self.centres) / self.widths
        return self.f_scale * (self.bias + _dot_last(np.exp(-r * r), self.weights))

    __call__ = predict

    def predict_numba(self, v: Any) -> np.ndarray:
        v = np.ascontiguousarray(np.asarray(v, dtype=float).ravel())
        return _rbf_eval(v, self.centres, self.widths, self.weights, float(self.bias),
                         float(self.v_scale), float(self.f_scale), np.empty_like(v))

    def to_torch(self, dtype: Any = None):
        import torch

        _, rbf_cls = torch_module_classes()
        dtype = torch.float64 if dtype is None else dtype
        m = rbf_cls(self.n_units).to(dtype)
        with torch.no_grad():
            m.centres.copy_(torch.as_tensor(self.centres, dtype=dtype))
            m.widths.copy_(torch.as_tensor(self.widths, dtype=dtype))
            m.weight.copy_(torch.as_tensor(self.weights, dtype=dtype))
            m.bias.copy_(torch.as_tensor(self.bias, dtype=dtype))
            m.v_scale.fill_(self.v_scale)
            m.f_scale.fill_(self.f_scale)
        return m

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "centres": self.centres.tolist(), "widths": self.widths.tolist(),
                "weights": self.weights.tolist(), "bias": self.bias, "v_scale": self.v_scale,
                "f_scale": self.f_scale, "metrics": dict(self.metrics)}


def fit_rbf(
    points: FrictionPoints | Any,
    force: Any = None,
    *,
    n_units: int = 50,
    seed: int | None = 0,
    width_factor: float = 1.5,
    rcond: float = 1e-10,
    warp: bool = True,
) -> RBFFriction:
    """Fit the 002 sec. 5 RBF net: k-means centres, spacing widths, least-squares weights.

    ``n_units`` is capped by the number of distinct velocities (duplicate k-means centres are
    merged). Needs more points than ``n_units + 1`` unknown output weights.
    """
    v, f = _xy(points, force)
    k = int(n_units)
    if k < 2:
        raise ValueError(f"n_units must be >= 2, got {n_units}")
    if not (width_factor > 0):
        raise ValueError(f"width_factor must be > 0, got {width_factor}")
    if v.size < k + 2:
        raise InsufficientDataError(
            f"the RBF net with {k} units has {k + 1} output weights and needs at least "
            f"{k + 2} points; got {v.size}"
        )
    v_scale = float(np.max(np.abs(v))) or 1.0
    f_scale = float(np.max(np.abs(f))) or 1.0
    z = v / v_scale
    y = f / f_scale
    rng = np.random.default_rng(seed)
    # k-means per direction: friction jumps at v = 0, and a centre must not average points of
    # both directions (a cluster of the two slowest points, one per direction, sits at v = 0)
    sides = [z[z > 0], z[z < 0]]
    sides = [s for s in sides if s.size]
    counts = np.array([s.size for s in sides], dtype=float)
    alloc = np.maximum(1, np.round(k * counts / counts.sum()).astype(int))
    alloc[-1] = max(1, k - int(alloc[:-1].sum()))
    centres, widths_l = [], []
    for s, k_s in zip(sides, alloc):
        k_s = int(min(k_s, np.unique(s).size))
        warped = np.sqrt(np.abs(s)) if warp else np.abs(s)
        c_w, _ = kmeans2(warped.reshape(-1, 1), k_s, minit="++", seed=rng, iter=50, missing="warn")
        c_w = np.abs(c_w.ravel())
        c_s = np.sign(s[0]) * (c_w * c_w if warp else c_w)
        c_s = np.unique(np.round(c_s, 14))
        if c_s.size >= 2:
            d = np.abs(c_s[:, None] - c_s[None, :])
            np.fill_diagonal(d, np.inf)
            w_s = np.sort(d, axis=1)[:, : min(2, c_s.size - 1)].mean(axis=1)
        else:
            w_s = np.array([max(float(np.ptp(s)), float(np.abs(s).min()), 1e-6)])
        centres.append(c_s)
        widths_l.append(w_s)
    c = np.concatenate(centres)
    if c.size < 2:
        raise InsufficientDataError("need at least two distinct velocities for an RBF net")
    # cap: a unit must not reach across v = 0 (s_j <= |c_j| / 2 puts v = 0 at exp(-4) = 2 %)
    widths = np.minimum(width_factor * np.concatenate(widths_l), 0.5 * np.abs(c))
    widths = np.maximum(widths, 1e-12)
    r = (z[:, None] - c[None, :]) / widths[None, :]
    phi = np.column_stack([np.exp(-r * r), np.ones(z.size)])
    sol, *_ = np.linalg.lstsq(phi, y, rcond=rcond)
    model = RBFFriction(c, widths, sol[:-1].copy(), float(sol[-1]), v_scale, f_scale)
    model.metrics = _metrics(f, model.predict(v))
    model.info = {"n_units_requested": k, "n_units": int(c.size), "seed": seed,
                  "width_factor": width_factor, "centres": "scipy.cluster.vq.kmeans2(++)"}
    return model


def fit_neural_friction(points: FrictionPoints | Any, force: Any = None, *, kind: str = "feedforward",
                        seed: int | None = 0, **kwargs: Any):
    """``kind`` = ``"feedforward"`` (:func:`fit_feedforward`) or ``"rbf"`` (:func:`fit_rbf`)."""
    if kind in ("feedforward", "ff", "neural_ff"):
        return fit_feedforward(points, force, seed=seed, **kwargs)
    if kind in ("rbf", "neural_rbf"):
        return fit_rbf(points, force, seed=seed, **kwargs)
    raise ValueError(f"unknown neural model kind {kind!r}; use 'feedforward' or 'rbf'")


def cross_validated_error(
    points: FrictionPoints | Any,
    force: Any = None,
    *,
    kind: str = "feedforward",
    folds: int = 5,
    seed: int | None = 0,
    **kwargs: Any,
) -> dict[str, float]:
    """E (eq (11)) and RMSE on held-out points, ``folds``-fold (shuffled with ``seed``).

    The paper's E is a training error; this is the generalisation error of the same net.
    """
    v, f = _xy(points, force)
    rng = np.random.default_rng(seed)
    idx = rng.permutation(v.size)
    parts = np.array_split(idx, int(folds))
    pred = np.empty_like(f)
    for test in parts:
        train = np.setdiff1d(idx, test)
        m = fit_neural_friction(v[train], f[train], kind=kind, seed=seed, **kwargs)
        pred[test] = m.predict(v[test])
    return {"E": mean_absolute_error(f, pred), "rmse": rmse(f, pred), "nrmse": nrmse(f, pred),
            "folds": int(folds)}


# ======================================================================================
# torch export (lazy import)
# ======================================================================================


@functools.lru_cache(maxsize=1)
def torch_module_classes():
    """The ``torch.nn.Module`` classes ``(FeedForwardFrictionModule, RBFFrictionModule)``.

    Both map a velocity tensor [m/s] of any shape to the friction force [N] of the same shape.
    Created on first use so that importing this module never imports torch.
    """
    import torch
    from torch import nn

    class FeedForwardFrictionModule(nn.Module):
        """002 sec. 5 feed-forward friction net: ``f_s (out(tanh(hidden(v / v_s))))``."""

        def __init__(self, n_hidden: int = 10) -> None:
            super().__init__()
            self.hidden = nn.Linear(1, n_hidden)
            self.out = nn.Linear(n_hidden, 1)
            self.register_buffer("v_scale", torch.ones(()))
            self.register_buffer("f_scale", torch.ones(()))

        def forward(self, v: torch.Tensor) -> torch.Tensor:
            z = (v / self.v_scale).unsqueeze(-1)
            return self.f_scale * self.out(torch.tanh(self.hidden(z))).squeeze(-1)

    class RBFFrictionModule(nn.Module):
        """002 sec. 5 RBF friction net: ``f_s (b + sum_j w_j exp(-((v/v_s - c_j)/s_j)^2))``."""

        def __init__(self, n_units: int = 50) -> None:
            super().__init__()
            self.register_buffer("centres", torch.zeros(n_units))
            self.register_buffer("widths", torch.ones(n_units))
            self.weight = nn.Parameter(torch.zeros(n_units))
            self.bias = nn.Parameter(torch.zeros(()))
            self.register_buffer("v_scale", torch.ones(()))
            self.register_buffer("f_scale", torch.ones(()))

        def forward(self, v: torch.Tensor) -> torch.Tensor:
            r = ((v / self.v_scale).unsqueeze(-1) - self.centres) / self.widths
            return self.f_scale * (self.bias + torch.exp(-r * r) @ self.weight)

    return FeedForwardFrictionModule, RBFFrictionModule


def torch_module_from_state_dict(state_dict: dict[str, Any]):
    """Rebuild the module saved by ``torch.save(model.to_torch().state_dict(), path)``.

    ``state_dict = torch.load(path, weights_only=True)``; the architecture (feed-forward or
    RBF, its size and dtype) is read from the tensor shapes.
    """
    ff_cls, rbf_cls = torch_module_classes()
    if "hidden.weight" in state_dict:
        w = state_dict["hidden.weight"]
        m = ff_cls(int(w.shape[0])).to(w.dtype)
    elif "centres" in state_dict:
        c = state_dict["centres"]
        m = rbf_cls(int(c.shape[0])).to(c.dtype)
    else:
        raise ValueError(
            "not a friction-net state_dict: expected 'hidden.weight' (feed-forward) or "
            f"'centres' (RBF); keys: {sorted(state_dict)}"
        )
    m.load_state_dict(state_dict)
    return m
