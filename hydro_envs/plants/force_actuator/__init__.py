"""High-bandwidth force actuator of seed 001 (``001_3253c61f41166c3e.txt``): jet-pipe valve on
the piston, U-shaped force sensor.

``params``, ``model`` (valve eq (7), fluid eq (8), sensor eq (2), seal friction eq (1) (the seal-friction family's Dahl case),
hydraulic damping eq (5), hysteresis), ``closed_loop`` (sec. 4.1 and 4.7 experiments),
``kernels``, ``energy``, ``validation``, ``spec``.
"""
