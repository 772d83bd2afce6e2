"""Registry entry of the valve-controlled differential cylinder (issue 54's data-sheet rig)."""

from hydro_envs.spec import Channel, EnvEntry, PlantSpec

SPEC = PlantSpec(
    name="differential_cylinder",
    title="valve-controlled differential (single-rod) cylinder, 4/3 proportional valve from a data sheet",
    source="issue 54 example rig: 63/36 x 300 mm, 160 bar, 40 L/min at 70 bar, 60 Hz; textbook model",
    channels=(
        Channel("u", "V", "valve command (+-10 V = full opening)"),
        Channel("x", "m", "piston position from the cap end of stroke (0..stroke)"),
        Channel("p1", "Pa", "absolute pressure in the cap-side (piston) chamber"),
        Channel("p2", "Pa", "absolute pressure in the rod-side (annulus) chamber"),
    ),
    inputs=("u",),
    package="hydro_envs.plants.differential_cylinder",
    params_class="DifferentialCylinderParams",
    envs=(
        EnvEntry(
            "hydro_envs/DifferentialCylinderPosition-v0",
            "hydro_envs.envs.differential_cylinder:DifferentialCylinderPositionEnv",
            "hydro_envs.envs.differential_cylinder:DifferentialCylinderPositionVectorEnv",
            2000,
        ),
        EnvEntry(
            "hydro_envs/DifferentialCylinderSlowSine-v0",
            "hydro_envs.envs.differential_cylinder:DifferentialCylinderSlowSineEnv",
            "hydro_envs.envs.differential_cylinder:DifferentialCylinderSlowSineVectorEnv",
            8000,
        ),
        EnvEntry(
            "hydro_envs/DifferentialCylinderMicroPosition-v0",
            "hydro_envs.envs.differential_cylinder:DifferentialCylinderMicroPositionEnv",
            "hydro_envs.envs.differential_cylinder:DifferentialCylinderMicroPositionVectorEnv",
            8000,
        ),
    ),
    stroke_parameter="stroke",
    pressure_parameter="supply_pressure",
    dry_friction_parameters=("coulomb_friction", "static_friction"),
    # assumed: the valve (60 Hz) and the oil spring (>= 130 Hz) need at least 50 Hz sampling
    max_sample_time=0.02,
    friction_test="two_areas",
)
