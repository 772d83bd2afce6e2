"""Viscous coefficient of the compensator spool from a two-pressure Bode measurement (seed 000).

:func:`fit_compensator_viscous` fits the one unknown of 000's methods 1 and 2 (the viscous
coefficient ``c`` of the spool at the test temperature) to the measured pressure ratios of a
virtual or real rig, with the plant linearised about each row's operating point.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from hydro_envs.plants.ls_compensator import model as lc

__all__ = ["fit_compensator_viscous"]


def fit_compensator_viscous(result: Any, params: Any = None, *, sampling: bool = True,
                            bounds: tuple[float, float] = (0.05, 100.0)) -> float:
    """Viscous coefficient ``c`` [N s/m] at the test temperature from a virtual-rig Bode
    measurement of 000, method 1 (``p2/p1``, :class:`hydro_envs.plants.ls_compensator.experiments.Method1Result`)
    or method 2 (eq (18) ``p_I/p_P``, ``Method2Result``, every row with its own mean pressure
    and orifice).

    The model is the kernel right-hand side linearised about each row's operating point
    (:func:`hydro_envs.plants.ls_compensator.linearize`), ``H(s) = e_k' (sI - A)^-1 B``
    with ``k`` = p2 (method 1) or p_out (method 2); ``c`` minimises
    ``sum |H_model - H_measured|^2`` (bounded scalar search on log c).

    *Sampling* (``sampling=True``): the rigs drive the plant with the first-order-hold
    (piecewise-linear) interpolant of the sampled inlet pressure, while the ratio divides by
    the first harmonic of the samples. The interpolant of a sampled sine has the first
    harmonic ``sinc^2(f T)`` times the sine's, in phase (the triangular FOH kernel is
    symmetric), so the measured ratio is ``sinc^2(f T) H(j w)`` and the model is multiplied by
    it. At 300 Hz / 20 kHz that is 0.07 %; it matters at high frequency or slow sampling.
    ``params``: model of everything else (default: the rig's own plant per row).
    """
    freq = np.asarray(result.frequency, dtype=float)
    ratio = np.asarray(result.ratio, dtype=complex)
    if hasattr(result, "mean_gauge"):  # method 2
        plants = list(result.params) if params is None else [params] * freq.size
        p_in = 1.0e5 + np.asarray(result.mean_gauge, dtype=float)
        out_index = lc.PO
        fs = 20e3 if not hasattr(result, "sample_rate") else float(result.sample_rate)
    else:
        plants = [result.params if params is None else params] * freq.size
        p_in = np.full(freq.size, 1.0e5 + lc.METHOD1_MEAN_GAUGE)
        out_index = lc.P2
        fs = 10e3 if not hasattr(result, "sample_rate") else float(result.sample_rate)
    corr = np.sinc(freq / fs) ** 2 if sampling else np.ones(freq.size)
    # group the rows by (plant, operating point): one linearisation per group and c
    groups: dict[tuple[int, float], list[int]] = {}
    uniq: list[Any] = []
    for i, (q, pi) in enumerate(zip(plants, p_in)):
        for j, u in enumerate(uniq):
            if u == q:
                break
        else:
            uniq.append(q)
            j = len(uniq) - 1
        groups.setdefault((j, float(pi)), []).append(i)

    def model_ratio(c_t: float) -> np.ndarray:
        h = np.empty(freq.size, dtype=complex)
        for (j, pi), idx in groups.items():
            q = uniq[j]
            d = lc.derived(q)
            nu_ratio = d["viscous"] / max(q.viscous_friction_40c + q.lvdt_friction_40c, 1e-300)
            if not math.isfinite(nu_ratio) or nu_ratio <= 0:
                nu_ratio = 1.0
            qc = dataclasses.replace(q, viscous_friction_40c=c_t / nu_ratio, lvdt_friction_40c=0.0)
            A, B = lc.linearize(qc, pi)
            n = A.shape[0]
            for i in idx:
                s = 2j * math.pi * freq[i]
                h[i] = np.linalg.solve(s * np.eye(n) - A, B)[out_index] * corr[i]
        return h

    def cost(log_c: float) -> float:
        return float(np.sum(np.abs(model_ratio(math.exp(log_c)) - ratio) ** 2))

    r = minimize_scalar(cost, bounds=(math.log(bounds[0]), math.log(bounds[1])), method="bounded",
                        options={"xatol": 1e-5})
    return float(math.exp(r.x))

