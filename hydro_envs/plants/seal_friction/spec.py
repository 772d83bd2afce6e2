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
)
