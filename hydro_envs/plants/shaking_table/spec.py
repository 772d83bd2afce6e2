"""Registry entry of the servo-hydraulic shaking table (seed 003)."""

from hydro_envs.spec import Channel, EnvEntry, PlantSpec

SPEC = PlantSpec(
    name="shaking_table",
    title="servo-hydraulic uni-axial shaking table, IFAS / modified-IFAS bulk modulus",
    source="003_54985feb8193da53.txt: eqs (1)-(19), Tables 1-3",
    channels=(
        Channel("u", "V", "valve command (+-10 V = full spool stroke)"),
        Channel("x", "m", "table position from mid-stroke (potentiometer)"),
        Channel("a", "m/s^2", "table acceleration (accelerometer)"),
        Channel("pa", "Pa", "chamber A pressure, absolute (transducer; not measured in 003)"),
        Channel("pb", "Pa", "chamber B pressure, absolute (transducer; not measured in 003)"),
    ),
    inputs=("u",),
    package="hydro_envs.plants.shaking_table",
    params_class="ShakingTableParams",
    envs=(
        EnvEntry(
            "hydro_envs/ShakingTable-v0",
            "hydro_envs.envs.shaking_table:ShakingTableEnv",
            "hydro_envs.envs.shaking_table:ShakingTableVectorEnv",
            6000,
        ),
        EnvEntry(
            "hydro_envs/ShakingTableLowFrequency-v0",
            "hydro_envs.envs.shaking_table:ShakingTableLowFrequencyEnv",
            "hydro_envs.envs.shaking_table:ShakingTableLowFrequencyVectorEnv",
            8000,
        ),
    ),
    stroke_parameter="stroke",
    pressure_parameter="supply_pressure",
    # assumed: 003 records at 1 kHz; coarser than 100 Hz misses the table's oil-column resonance
    max_sample_time=0.01,
    dry_friction_parameters=("coulomb_friction", "static_friction"),
)
