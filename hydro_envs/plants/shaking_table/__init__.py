"""Servo-hydraulic uni-axial shaking table of seed 003 (``003_54985feb8193da53.txt``).

``params`` (Tables 1-2, presets and specimens), ``model`` (eqs (1)-(19) right-hand side,
stiffness bound, closed-form analysis), ``analysis`` (analyses that run the model),
``kernels``, ``energy``, ``validation``, ``spec``.
"""
