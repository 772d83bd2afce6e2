r"""Friction identification: constant-velocity points, static fits, graphical construction,
Dahl and LuGre fits from time series.

Sources (the seed papers, ``docs/references.md``):

* ``002_af30b681d6ccfd6c.txt`` sec. 4: at constant velocity and no load the friction equals the
  actuator force, eqs (9)-(10) ``F_f = F_a = A (P1 - P2)`` (double-rod cylinder; the viscous
  term ``d v`` of eq (7) is part of the friction); exponential Stribeck model eq (1); the
  fitting error E of eq (11) (mean absolute error over the measurement points).
* ``004_f1423316a055addb.txt`` sec. 3: ``F_f = A_a p_a - A_b p_b`` eq (1) (unequal areas), the
  graphical construction of the Stribeck parameters sec. 3.1 / Fig. 3, Table 2.
* ``003_54985feb8193da53.txt`` eqs (11)-(12): Gaussian Stribeck model.
* ``001_3253c61f41166c3e.txt`` eq (1): Dahl model; LuGre (Canudas de Wit et al. 1995, ref [30]
  of 003, ref [6] of 002). The laws themselves are in :mod:`hydro_envs.laws.friction`.

Sign convention (as in :mod:`hydro_envs.laws.friction`): the friction force has the sign of
the velocity (it opposes motion), ``m a = F_drive - F_f``.

Static models
-------------
Every static model here has the form (``sgn`` is ``sign(v)``, or ``tanh(v / v_eps)`` when the
caller passes ``sign_velocity = v_eps > 0`` to match a regularised simulation)::

    F(v, p) = sgn(v) [F_c + k_p p + (F_s - F_c) phi(|v| / v_s)] + F_v v

    phi(r) = exp(-r)     "stribeck"            002 eq (1)
    phi(r) = exp(-r^2)   "stribeck_gaussian"   003 eq (11)
    (no phi term)        "coulomb_viscous", "coulomb" (also without F_v v)

The pressure term ``k_p p`` [N/Pa = m^2] is present only with ``pressure_dependent=True``;
``p`` is the pressure that loads the seals (the mean chamber pressure for a hydraulic cylinder,
the gauge chamber pressure for the pneumatic seal rig). It shifts the Coulomb *and* the static
level by the same amount (the seal's normal force grows with pressure; the Stribeck dip
height ``F_s - F_c`` is taken as pressure-independent) -- the simplest law that the seal data
(:mod:`identification.constant_velocity`, one speed per direction) can identify; Simscape's cylinder
friction uses the same linear growth with pressure. With ``pressure_dependent`` the reported
``F_c`` and ``F_s`` are the values at ``p = 0``.

Fitting is bounded nonlinear least squares (``scipy.optimize.least_squares``, trust-region
reflective) on the parameters. For a fixed ``v_s`` every model is *linear* in
``(F_c, k_p, F_s - F_c, F_v)``, so a grid over ``v_s`` with bounded linear least squares
(variable projection) gives a global starting point, which ``least_squares`` then polishes on
all parameters. Bounds: ``F_c, F_s - F_c, F_v >= 0`` (002 eq (1): all positive), ``v_s`` in
``[min|v| / 100, 10 max|v|]``, ``k_p`` free.

Covariance ``C = (J^T J)^-1 s^2`` with ``s^2 = SSR / (N - n_p)`` at the solution (``J`` the
Jacobian of the residuals in the reported parameters), standard errors ``sqrt(diag C)``.
These assume independent residuals of equal variance; window-averaged constant-velocity points
are close to that, raw autocorrelated time series are not (``docs/references.md``, numerics notes: naive standard
errors 1.6-2.2x too small there).

Identifiability: a fit raises :class:`UnidentifiableError` naming the parameters the data
cannot determine: ``F_s, v_s`` when the slowest point lies where the Stribeck term has decayed
below 5 % (no low-velocity points to see the dip), ``v_s`` when the fitted dip height is not
significant (``F_s - F_c`` below twice its standard error: no dip in the data), and any
parameter whose standard error moves the model force over the data's range (``F_c, F_s``:
itself, ``F_v``: times ``max |v|``, ``k_p``: times the pressure span) by more than
``max_rel_std_error`` (default 0.5) of the largest measured force, or ``v_s`` with a relative
standard error above it.
Too few points raise :class:`InsufficientDataError`.
"""

from identification.friction.data import IdentificationError, InsufficientDataError, UnidentifiableError, actuator_force, chamber_force, FrictionPoints, mean_absolute_error, rmse, nrmse
from identification.friction.static import STATIC_MODELS, static_friction, FrictionFit, AsymmetricFrictionFit, fit_friction
from identification.friction.graphical import GraphicalStribeck, graphical_stribeck
from identification.friction.dynamic import (
    DynamicFrictionFit, bristle_stiffness_from_loading, fit_dahl, fit_lugre, simulate_dahl, simulate_lugre,
)

__all__ = ['IdentificationError', 'InsufficientDataError', 'UnidentifiableError', 'actuator_force', 'chamber_force', 'FrictionPoints', 'mean_absolute_error', 'rmse', 'nrmse', 'STATIC_MODELS', 'static_friction', 'FrictionFit', 'AsymmetricFrictionFit', 'fit_friction', 'GraphicalStribeck', 'graphical_stribeck', 'DynamicFrictionFit', 'simulate_dahl', 'simulate_lugre', 'fit_dahl', 'fit_lugre', 'bristle_stiffness_from_loading']
