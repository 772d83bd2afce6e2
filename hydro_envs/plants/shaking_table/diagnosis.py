r"""What the diagnosis workflow needs to know about the shaking table, as plain data.

:data:`BASES` maps the name the workflow (:mod:`identification.diagnosis`) knows this rig by to
its base-model settings (keys described in :mod:`identification.diagnosis.plants`) and to
``effects``: each catalogue effect the table can carry and the fields of
:class:`~.params.ShakingTableParams` that realise it (fit bounds = physical plausibility, start
value, draw range of hidden-effect records, value when absent, prerequisites, source). Imports
nothing outside :mod:`hydro_envs`; the model is loaded when a function below is first called.

Stribeck friction is kept here only for its null value (static = Coulomb level in the base
model) and is never proposed (``diagnosable=False``): the catalogue was measured when the plant
read eq (12)'s beta in s/m (the soft sign tanh(7.33 v), v_eps = 0.14 m/s), which multiplied the
Stribeck excess by <= 0.2 at any speed where it had not decayed, and the fitted Coulomb level
absorbed it to within 4 % of the held-out error. The plant now has LuGre seals whose steady
state is eq (11) with the sign (beta read per mm/s, :class:`~.params.ShakingTableParams`); the
Stribeck effect has not been re-measured for diagnosability since, so it stays unproposed.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BASES", "initial_state", "controller"]

_TABLE = "003_54985feb8193da53.txt"


def _model():
    from hydro_envs.plants.shaking_table import model

    return model


def initial_state(params, m):
    """State at a window start: measured position, velocity and (when measured) pressures, the
    rest of the rest state; the spool at its static position for the command."""
    st = _model()
    y = st.rest_state(params, m["x"], m.get("v", 0.0))
    y[st.PA] = m.get("pa", y[st.PA])
    y[st.PB] = m.get("pb", y[st.PB])
    y[st.XV] = float(np.clip(params.spool_gain * m.get("u", 0.0), -1.0, 1.0))
    return y


def controller(meas, ref, params):
    """P position loop with velocity feedforward through the no-load valve gain; K_v = 6 1/s
    stays below the oil column's 2 zeta_h omega_h (~10 1/s: omega_h = 54 rad/s at 200 kg,
    zeta_h ~ 0.1), 25 1/s made the loop limit-cycle at full valve opening."""
    kq = _model().no_load_velocity(params) / params.command_max  # m/s per V
    u = (6.0 * (ref[0] - meas["x"]) + ref[1]) / kq
    return float(np.clip(u, -params.command_max, params.command_max))


def _reference_centre(p):
    return 0.0


def _ifas_present(p):
    return p.bulk_modulus_model >= 1.0


def _modified_ifas_present(p):
    return p.bulk_modulus_model == 2.0 and p.lambda_2 > 0.0


_EFFECTS = {
    "coulomb": dict(
        parameters=(dict(field="coulomb_friction", bounds=(5.0, 2e4), start=400.0, draw=(300.0, 900.0)),),
        null={"coulomb_friction": 0.0},
        source=f"{_TABLE} eq (11) F_c; Table 2: 573.7 N (modified IFAS), 531.9 N (IFAS)"),
    "stribeck": dict(
        parameters=(dict(field="static_friction", bounds=(5.0, 2e4), start=1.8, draw=(1.5, 2.4),
                         relative_to="coulomb_friction"),
                    dict(field="stribeck_velocity", bounds=(1e-3, 0.5), start=0.06, draw=(0.04, 0.1))),
        null={"static_friction": "coulomb_friction"}, requires=("coulomb",),
        ties={"static_friction": "coulomb_friction"}, diagnosable=False,
        source=f"{_TABLE} eqs (11)-(12); Table 2: F_s/F_c = 2.19 / 1.79, v_s = 0.014 / 0.08 m/s "
        "(not diagnosable: see the module docstring)"),
    "internal_leakage": dict(
        parameters=(dict(field="internal_leakage", bounds=(1e-15, 1e-10), start=1e-12, draw=(1e-12, 4e-12)),),
        null={"internal_leakage": 0.0},
        source=f"{_TABLE} eqs (4)-(5) C_il; Table 2: 4.343e-13 m^3/(s Pa)"),
    "ifas": dict(
        parameters=(dict(field="air_content", bounds=(1e-6, 0.05), start=3e-3, draw=(2e-3, 1e-2)),),
        null={"bulk_modulus_model": 0.0}, switch={"bulk_modulus_model": 1.0}, present=_ifas_present,
        source=f"{_TABLE} eq (13) IFAS; entrained air 0.2-1 % of a hydraulic oil at atmosphere"),
    "modified_ifas": dict(
        parameters=(dict(field="lambda_2", bounds=(1e-3, 0.49), start=0.2, draw=(0.15, 0.42)),),
        null={"lambda_2": 0.0}, switch={"bulk_modulus_model": 2.0, "lambda_1": 1.0}, requires=("ifas",),
        present=_modified_ifas_present,
        source=f"{_TABLE} eq (19), Table 2 (lambda_2 = 0.32 valid reading; h > 0 needs "
        "lambda_2 < 0.54)"),
    "sensor_delay": dict(
        parameters=(dict(field="delay", bounds=(1e-5, 0.05), start=2e-3, draw=(2e-3, 6e-3), log=False),),
        null={"delay": 0.0}, channels=("x",),
        source="assumed: potentiometer acquisition delay of 1-10 ms"),
}

#: base-model settings of the shaking table (see the module docstring)
BASES = {
    "shaking_table": dict(
        base_fit=("e0", "flow_coefficient"),  # viscous friction stays at 003 Table 2 (429.4 N s/m)
        # 16-bit potentiometer over 300 mm (4.6 um step), ADXL05-class accelerometer,
        # 0.05 bar filtered pressure transducers (optional channels: 003 measured x and a only)
        noise={"x": 2e-6, "a": 0.02, "pa": 5e3, "pb": 5e3, "u": 0.0},
        initial_state=initial_state, controller=controller,
        position_channel="x", position_state="x",
        reference_centre=_reference_centre, reference_amplitude=0.05, reference_speed=0.08,
        # warm-up: the oil column's ~0.18 s (truth-model floor of the held-out NRMSE: 0.05 with
        # 0.1 s, 0.0015 with 0.3 s, measured)
        segment_seconds=0.8, warmup_seconds=0.3, score_bandwidth=50.0,
        offset_free=("x",), sensor_offsets=("pa", "pb"),
        # the example of ``make demo-diagnose``: (hidden effect, seed); base model: IFAS bulk modulus
        demo=("modified_ifas", 12),
        # verdict unexplained above 12 noise floors: correct models left up to 5.9 floors (effect-free
        # record, pa; measured on one 5 s record per case)
        unexplained_factor=12.0,
        effects=_EFFECTS,
    ),
}
