"""Registry entry of measured seal-friction records: a rod driven back and forth at about
constant speed through a pressurised chamber, its seal friction on a load cell. Measured
channels only; the friction laws are fitted by :mod:`identification`."""

from hydro_envs.spec import Channel, PlantSpec

SPEC = PlantSpec(
    name="seal_friction",
    title="pneumatic cylinder seal friction test (rod at constant speed, pressurised chamber)",
    source="tests/data/pneumatic_seal_friction/README.md (CC0 records)",
    channels=(
        Channel("x", "m", "rod displacement (driven back and forth at about constant speed)"),
        Channel("p_gauge", "Pa", "chamber pressure above atmosphere (gauge), held constant"),
        Channel("F_load", "N", "load-cell force on the rod"),
    ),
    # assumed: the bench's logger runs at 60-100 Hz with pauses (README), its rod travels less than
    # 1 m (40 mm in the shipped records) against at most 10 kN at up to 500 bar gauge
    max_sample_time=0.5,
    max_stroke=1.0,
    max_pressure=5e7,
    max_force=1e4,
    regular_clock=False,
    friction_test="strokes",
)
