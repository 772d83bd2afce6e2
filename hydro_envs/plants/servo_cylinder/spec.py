"""Registry entry of the valve-controlled servo cylinder (seed 002)."""

from hydro_envs.spec import Channel, EnvEntry, PlantSpec

SPEC = PlantSpec(
    name="servo_cylinder",
    title="valve-controlled double-rod servo cylinder, Moog D765 servo-valve",
    source="002_af30b681d6ccfd6c.txt: eq (8), friction eq (1), Table 1",
    channels=(
        Channel("u", "V", "servo-valve command (+-10 V = full spool stroke)"),
        Channel("x", "m", "piston position from the chamber-1 end of stroke (0..stroke)"),
        Channel("p1", "Pa", "absolute pressure in chamber 1"),
        Channel("p2", "Pa", "absolute pressure in chamber 2"),
    ),
    inputs=("u",),
    package="hydro_envs.plants.servo_cylinder",
    params_class="ServoCylinderParams",
    envs=(
        EnvEntry(
            "hydro_envs/ServoCylinderPosition-v0",
            "hydro_envs.envs.servo_cylinder:ServoCylinderPositionEnv",
            "hydro_envs.envs.servo_cylinder:ServoCylinderPositionVectorEnv",
            2000,
        ),
        EnvEntry(
            "hydro_envs/ServoCylinderSlowSine-v0",
            "hydro_envs.envs.servo_cylinder:ServoCylinderSlowSineEnv",
            "hydro_envs.envs.servo_cylinder:ServoCylinderSlowSineVectorEnv",
            8000,
        ),
        EnvEntry(
            "hydro_envs/ServoCylinderMicroPosition-v0",
            "hydro_envs.envs.servo_cylinder:ServoCylinderMicroPositionEnv",
            "hydro_envs.envs.servo_cylinder:ServoCylinderMicroPositionVectorEnv",
            8000,
        ),
    ),
    stroke_parameter="stroke",
    pressure_parameter="supply_pressure",
    dry_friction_parameters=("coulomb_friction", "static_friction", "friction_pressure_coefficient"),
    # assumed: 002 samples at 1 kHz (sec. 3); coarser than 50 Hz misses the valve and the hydraulic
    # resonance (hundreds of rad/s)
    max_sample_time=0.02,
    friction_test="annulus",
)
