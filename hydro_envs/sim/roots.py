"""Root of a scalar function on a bracket (Brent's method), without importing scipy.optimize.

:func:`brent_root` is Brent's method (R. P. Brent, *Algorithms for Minimization without
Derivatives*, 1973, ch. 4) in the variant of ``scipy.optimize.brentq`` (C. Harris): secant
steps, inverse quadratic extrapolation while the function values fall, bisection otherwise,
and never a step shorter than half the tolerance. It takes the same floating-point steps as
scipy's, so it returns the same number (tested against ``scipy.optimize.brentq``). The envs
solve their rest states with it (the shaking table's null and air-release pressures, the
rodless cylinder's centre pressure), so that making and resetting an env does not import
``scipy.optimize`` (0.47 s).
"""

from __future__ import annotations

import sys
from typing import Callable

__all__ = ["brent_root"]

_EPS = sys.float_info.epsilon


def brent_root(f: Callable[[float], float], a: float, b: float, xtol: float = 2e-12,
               rtol: float = 4 * _EPS, maxiter: int = 100) -> float:
    """A root of ``f`` in ``[a, b]`` (``f(a)`` and ``f(b)`` of opposite signs, or one of them 0).

    Converged when the bracket is narrower than ``xtol + rtol |x|`` (``scipy.optimize.brentq``'s
    tolerances and defaults). ``ValueError`` if ``f(a)`` and ``f(b)`` have the same sign or the
    tolerances are too small, ``RuntimeError`` after ``maxiter`` steps without convergence.
    """
    if not (xtol > 0.0):
        raise ValueError(f"xtol must be > 0, got {xtol}")
    if not (rtol >= 4 * _EPS):
        raise ValueError(f"rtol must be >= 4 eps = {4 * _EPS}, got {rtol}")
    x_prev, x = float(a), float(b)
    f_prev, fx = f(x_prev), f(x)
    if f_prev * fx > 0.0:
        raise ValueError(f"f(a) = {f_prev} and f(b) = {fx} must have different signs (a = {a}, b = {b})")
    if f_prev == 0.0:
        return float(x_prev)
    if fx == 0.0:
        return float(x)
    x_far = f_far = 0.0  # the other end of the bracket [x, x_far]
    step = step_prev = 0.0
    for _ in range(maxiter):
        if f_prev * fx < 0.0:  # the last step crossed the root: the bracket's far end is the previous point
            x_far, f_far = x_prev, f_prev
            step = step_prev = x - x_prev
        if abs(f_far) < abs(fx):  # keep the better point as x
            x_prev, x, x_far = x, x_far, x
            f_prev, fx, f_far = fx, f_far, fx
        half_tol = (xtol + rtol * abs(x)) / 2
        half_bracket = (x_far - x) / 2
        if fx == 0.0 or abs(half_bracket) < half_tol:
            return float(x)
        bisect = True
        if abs(step_prev) > half_tol and abs(fx) < abs(f_prev):
            if x_prev == x_far:  # secant through x and x_prev
                trial = -fx * (x - x_prev) / (fx - f_prev)
            else:  # inverse quadratic extrapolation through x, x_prev and x_far
                slope_prev = (f_prev - fx) / (x_prev - x)
                slope_far = (f_far - fx) / (x_far - x)
                trial = -fx * (f_far * slope_far - f_prev * slope_prev) / (slope_far * slope_prev * (f_far - f_prev))
            if 2 * abs(trial) < min(abs(step_prev), 3 * abs(half_bracket) - half_tol):
                step_prev, step = step, trial
                bisect = False
        if bisect:
            step_prev = step = half_bracket
        x_prev, f_prev = x, fx
        x += step if abs(step) > half_tol else (half_tol if half_bracket > 0.0 else -half_tol)
        fx = f(x)
    raise RuntimeError(f"brent_root did not converge in {maxiter} steps (last x = {x}, f(x) = {fx})")
