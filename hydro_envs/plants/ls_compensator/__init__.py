"""Load-sensing pump flow compensator of seed 000 (``000_d7d5fd9bd6b165a2.txt``): the spool
valve fed through a pilot pipe, and the two virtual test rigs that measure its damping.

``params`` (Table 1 and the geometry backed out of it), ``model`` (pipe RLC eqs (1)-(3),
spool eq (4), continuity (5)-(6), transfer functions (11)-(17)), ``experiments`` (method 1:
servovalve sine sweep; method 2: gear-pump ripple), ``kernels``, ``validation``, ``spec``.
"""
