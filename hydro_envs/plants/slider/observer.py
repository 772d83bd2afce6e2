"""Position of the driven body behind a play, implied by a measured record of the slider.

With a play between the driven body and the measured load (``backlash_gap > 0``,
:func:`~.model.slider_rhs`) the drive's position is not measured, and where it sits inside the
play decides what the next force does: pushing a load it touches moves the load at once, pushing
across the play first moves the drive alone. A simulation window started with the drive on the
wrong side of the play replays a different lost motion: on an independent two-body record
(0.1 mm play) the true model left 100-540 um RMS per 1 s window from the wrong side and 3-15 um
from the right one.

:func:`drive_track` integrates the driven body alone, under the recorded force, with the load
moving as measured: ``(1 - mu) m v_d' = f - (1 - mu) (F_0 + F_f(v_d)) - F_c(x_d - x, v_d - v)``
(the model's second body, :func:`~.model.slider_rhs`), the load's position and velocity
interpolated linearly between samples, classical RK4 with sub-steps from the drive's stiffness
bound (friction slope and contact mode), from the drive at the load at the first sample. The
contact keeps the track within the play of the measured position, so a start error is forgotten
at the first contact.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.contact import backlash_force
from hydro_envs.plants.slider.model import backlash_contact_rate, drive_acceleration, stiffness_modes
from hydro_envs.plants.slider.params import I_AC, I_GAP, I_KC, SliderParams
from hydro_envs.sim.stiffness import substeps_from_stiffness

__all__ = ["drive_track"]


@nb.njit(cache=True, error_model="numpy", inline="always")
def _drive_accel(p, xd, vd, xl, vl, f):
    """The model's driven body against the load at ``xl``, ``vl`` as measured."""
    return drive_acceleration(p, vd, f, backlash_force(xd - xl, vd - vl, p[I_GAP], p[I_KC], p[I_AC]))


@njit_noalloc
def _track(p, x, v, f, dt, n_sub, xd_out, vd_out):
    n = x.shape[0]
    h = dt / n_sub
    xd = x[0]
    vd = v[0]
    for k in range(n):
        xd_out[k] = xd
        vd_out[k] = vd
        if k == n - 1:
            break
        x0, x1, v0, v1 = x[k], x[k + 1], v[k], v[k + 1]
        for j in range(n_sub):
            s0 = j / n_sub
            sm = (j + 0.5) / n_sub
            s1 = (j + 1.0) / n_sub
            xa, va = x0 + s0 * (x1 - x0), v0 + s0 * (v1 - v0)
            xm, vm = x0 + sm * (x1 - x0), v0 + sm * (v1 - v0)
            xb, vb = x0 + s1 * (x1 - x0), v0 + s1 * (v1 - v0)
            a1 = _drive_accel(p, xd, vd, xa, va, f[k])
            a2 = _drive_accel(p, xd + 0.5 * h * vd, vd + 0.5 * h * a1, xm, vm, f[k])
            a3 = _drive_accel(p, xd + 0.5 * h * (vd + 0.5 * h * a1), vd + 0.5 * h * a2, xm, vm, f[k])
            a4 = _drive_accel(p, xd + h * (vd + 0.5 * h * a2), vd + h * a3, xb, vb, f[k])
            xd += h * (vd + h / 6.0 * (a1 + a2 + a3))
            vd += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)


def drive_track(params: SliderParams, x: np.ndarray, f: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Driven-body position [m] and velocity [m/s] at every sample of a record (module
    docstring): measured load position ``x`` [m] (noise-reduced), applied force ``f`` [N] held
    over each sample, sample time ``dt`` [s]. Without a play the drive is the load."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    v = np.gradient(x, dt)
    if params.backlash_gap <= 0.0:
        return x.copy(), v
    f = np.ascontiguousarray(f, dtype=np.float64)
    md = (1.0 - params.load_mass_fraction) * params.mass
    modes = {"friction": stiffness_modes(params)["friction"], "contact": backlash_contact_rate(params, md)}
    n_sub = substeps_from_stiffness(modes, dt)[0]
    xd = np.empty_like(x)
    vd = np.empty_like(x)
    _track(params.to_array(), x, v, f, dt, n_sub, xd, vd)
    return xd, vd
