"""Valve-controlled double-rod servo cylinder of seed 002 (``002_af30b681d6ccfd6c.txt``).

``params`` (Table 1 parameters), ``model`` (eq (8) right-hand side, stiffness bound,
analysis), ``kernels`` (compiled integration), ``energy`` (balance terms), ``validation``
(rows against the seed), ``spec`` (registry entry).
"""
