"""Valve-controlled differential (single-rod) cylinder made from a data sheet (issue 54).

No seed paper: the rig is the issue's example bench (63 mm bore, 36 mm rod, 300 mm stroke,
160 bar supply, a 40 L/min proportional valve), every value given as a data sheet gives it.
``params`` (the data-sheet fields and their derived columns), ``model`` (right-hand side,
stiffness bound, analysis), ``kernels`` (compiled integration), ``energy`` (balance terms),
``datasheet`` (the parameter file with units; ``configs/datasheets/`` ships the example rig's),
``friction_test`` (the virtual constant-velocity test), ``validation`` (rows against analytic
results), ``spec`` (registry entry).
"""
