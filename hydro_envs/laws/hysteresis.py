"""Rate-independent hysteresis: play operators and a Prandtl-Ishlinskii (Preisach-class) model.

Source: ``001_3253c61f41166c3e.txt`` sec. 3.3 ("a model ... capable of generating minor loops
from the knowledge of the major hysteresis loop", ref [4]; input valve current, output the DC
valve pipe tip position). The Prandtl-Ishlinskii model is the Preisach model restricted to
play (backlash) operators; it is fixed by its major loop and generates nested minor loops by
the Masing rule, which is what sec. 3.3 asks of the model.

Why play operators and not a Bouc-Wen ODE: a Bouc-Wen state integrates ``dz = f(z) di``; under a
zero-order-held current it would need an event update at every input jump, and under a fast
current ramp its time derivative is stiff (rate ~ |di/dt| / width). A play operator is a
projection, ``p <- clamp(p, u - r, u + r)``: exact for any monotone input segment, no time
step restriction, so a plant evaluates the operators algebraically in its right-hand side and
updates their memory in its guard after each sub-step (exact whenever the input is monotone
over the sub-step).

Model (input ``u`` and output in the same normalised unit, ``n`` plays)::

    y = w0 u + sum_k w p_k,     p_k = play(u; r_k),   w = (1 - w0) / n,  r_k = R k / n
    R = h n / ((1 - w0) (n + 1))

* far from a reversal every play is dragged (p_k = u -+ r_k) and ``y = u -+ h/2``: the major
  loop is the identity shifted by half the width, so its full horizontal width is exactly
  ``h`` (the configured width) and its slope is 1;
* right after a reversal every play is stuck: the branch slope is ``w0`` (``reversal_slope``)
  and rises in n steps back to 1 over an input travel ``2 R`` (Masing: the loading curve
  scaled by two);
* an oscillation of amplitude ``a`` moves only the plays with ``r_k < a``: a smaller minor
  loop inside the major one, whose width shrinks with ``a`` (zero for ``a < r_1``).
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["play_operator", "pi_threshold_scale", "pi_output", "pi_memories"]


@nb.njit(cache=True, error_model="numpy")
def play_operator(p, u, r):
    """Play (backlash) operator update: ``clamp(p, u - r, u + r)``.

    Units: any, consistent (p, u, r in the same unit). Exact for monotone ``u``.
    Source: Prandtl-Ishlinskii / Preisach hysteresis (001 sec. 3.3, ref [4]).
    """
    lo = u - r
    hi = u + r
    if p < lo:
        return lo
    if p > hi:
        return hi
    return p


@nb.njit(cache=True, error_model="numpy")
def pi_threshold_scale(width, reversal_slope, n):
    """Largest play threshold ``R`` that gives a major loop of full width ``width``.

    ``R = width n / ((1 - w0) (n + 1))`` with ``w0 = reversal_slope`` in [0, 1).
    """
    return width * n / ((1.0 - reversal_slope) * (n + 1.0))


@nb.njit(cache=True, error_model="numpy")
def pi_output(u, memory, width, reversal_slope):
    """Output of the Prandtl-Ishlinskii model for input ``u`` and play memories ``memory``.

    ``memory`` holds the plays' values at the end of the last update (a 1-D array of n
    entries); this function does not modify it (see :func:`play_operator` for the update).
    Units: output in the unit of ``u``.
    """
    n = memory.shape[0]
    big_r = pi_threshold_scale(width, reversal_slope, n)
    w = (1.0 - reversal_slope) / n
    y = reversal_slope * u
    for k in range(n):
        y += w * play_operator(memory[k], u, big_r * (k + 1) / n)
    return y


@nb.njit(cache=True, error_model="numpy")
def pi_memories(u, width, reversal_slope, n):
    """Memories of the ``n`` plays of the Prandtl-Ishlinskii model after each sample of the
    input sequence ``u`` (demagnetised start, all memories 0): row ``k`` after ``u[k]``.

    Exact when the input is monotone between samples (each update is a projection)."""
    big_r = pi_threshold_scale(width, reversal_slope, n)
    out = np.empty((u.shape[0], n))
    h = np.zeros(n)
    for k in range(u.shape[0]):
        for j in range(n):
            h[j] = play_operator(h[j], u[k], big_r * (j + 1) / n)
            out[k, j] = h[j]
    return out
