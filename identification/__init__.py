"""Identification tools that calibrate the hydro-envs plants from measured data.

Modules (import them explicitly; this package imports nothing heavy so that the ``hydro``
command line stays fast):

* :mod:`identification.constant_velocity` -- friction points from constant-velocity records:
  the square-wave test of 002 sec. 4 and the plant-agnostic test of 004 sec. 3.2 (steady
  windows found in the record). The virtual experiments themselves live with their plants
  (``hydro_envs.plants.<plant>.friction_test`` / ``experiments``).
* :mod:`identification.seal_friction` -- the measured seal-friction strokes (CC0): loader and
  friction points.
* :mod:`identification.friction` -- friction points and fits: Stribeck (exponential 002 eq (1),
  Gaussian 003 eq (11)) by bounded nonlinear least squares with covariance, the graphical
  construction of 004 sec. 3.1, per-direction and pressure-dependent variants, Dahl and LuGre
  fits from time series.
* :mod:`identification.neural` -- the neural friction models of 002 sec. 5 (feed-forward net
  trained by Levenberg-Marquardt, RBF net), numpy/numba evaluation and torch export.
* :mod:`hydro_envs.plants.servo_cylinder.compensation` -- friction feedforward for the servo cylinder (force ->
  load pressure -> valve command through the orifice law).
* :mod:`identification.cli` -- ``hydro identify METHOD ...`` (a registry of methods).
"""
