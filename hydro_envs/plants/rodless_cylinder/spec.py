"""Registry entry of the pneumatic rodless cylinder (seed 004)."""

from hydro_envs.spec import Channel, EnvEntry, PlantSpec

SPEC = PlantSpec(
    name="rodless_cylinder",
    title="pneumatic rodless cylinder SMC MYC25G with FESTO MPYE-5 proportional valve",
    source="004_f1423316a055addb.txt: eqs (1)-(27), Table 2, eq (32)",
    channels=(
        Channel("u", "V", "proportional valve command (0-10 V, closed centre at 5 V)"),
        Channel("y", "m", "carriage position from the chamber-a end of stroke (0..stroke)"),
        Channel("pa", "Pa", "absolute pressure in chamber a"),
        Channel("pb", "Pa", "absolute pressure in chamber b"),
    ),
    inputs=("u",),
    package="hydro_envs.plants.rodless_cylinder",
    params_class="RodlessCylinderParams",
    envs=(
        EnvEntry(
            "hydro_envs/RodlessCylinder-v0",
            "hydro_envs.envs.rodless_cylinder:RodlessCylinderEnv",
            "hydro_envs.envs.rodless_cylinder:RodlessCylinderVectorEnv",
            2000,
        ),
        EnvEntry(
            "hydro_envs/RodlessCylinderSlowSine-v0",
            "hydro_envs.envs.rodless_cylinder:RodlessCylinderSlowSineEnv",
            "hydro_envs.envs.rodless_cylinder:RodlessCylinderSlowSineVectorEnv",
            4000,
        ),
        EnvEntry(
            "hydro_envs/RodlessCylinderMicroPosition-v0",
            "hydro_envs.envs.rodless_cylinder:RodlessCylinderMicroPositionEnv",
            "hydro_envs.envs.rodless_cylinder:RodlessCylinderMicroPositionVectorEnv",
            3000,
        ),
    ),
    experiments=("constant_command_run", "small_signal_response"),
    stroke_parameter="stroke",
    pressure_parameter="supply_pressure",
    dry_friction_parameters=("coulomb_friction", "static_friction"),
    # assumed: 004 samples at 1 kHz; coarser than 50 Hz misses the pneumatic spring's resonance
    max_sample_time=0.02,
)
