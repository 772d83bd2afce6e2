"""Load-sensing pump circuit of seed 000 Fig. 1 (``000_d7d5fd9bd6b165a2.txt``): an axial piston
pump whose displacement two control pistons set, the seed's flow compensator, the main
control valve and one actuator with its load.

``params``, ``model``, ``kernels``, ``energy``, ``spec``.
"""
