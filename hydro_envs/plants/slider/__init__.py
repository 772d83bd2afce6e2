"""Generic force-driven slider: a rigid axis with mass, Stribeck friction (002 eq (1)), a
force offset and end stops; the plant of rigid-axis identification (inverse dynamics).

``params``, ``model`` (right-hand side, stiffness bound, :func:`~.model.simulate_slider`),
``kernels``, ``spec``.
"""
