"""Pneumatic rodless cylinder of seed 004 (``004_f1423316a055addb.txt``).

``params``, ``model`` (eqs (2)-(16) right-hand side, linearisation eqs (19)-(27)),
``experiments`` (constant-command friction test of sec. 3, small-step response), ``kernels``,
``energy``, ``validation``, ``spec``.
"""
