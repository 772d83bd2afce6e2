"""Servo-hydraulic uni-axial shaking table of seed 003 (``003_54985feb8193da53.txt``).

``params`` (Tables 1-2, presets and specimens), ``model`` (eqs (1)-(19) right-hand side,
local refinement, closed-form analysis), ``bounds`` (the stiffness bounds that size the RK4
sub-steps and their local refinement), ``analysis`` (analyses that run the model),
``kernels``, ``energy``, ``validation``, ``spec``.
"""
