"""Registry entry of the load-sensing pump circuit built around the seed-000 flow compensator."""

from hydro_envs.spec import Channel, EnvEntry, PlantSpec

SPEC = PlantSpec(
    name="load_sensing",
    title="load-sensing pump circuit: variable pump, seed-000 flow compensator, control valve, actuator",
    source="000_d7d5fd9bd6b165a2.txt: sec. 2, Fig. 1; compensator eqs (1)-(6)",
    channels=(
        Channel("f_sol", "N", "electro-proportional force command on the FC spool (adds to the spring)"),
        Channel("a_cv", "m^2", "main control valve (CV) flow area"),
        Channel("p_s", "Pa", "absolute pump delivery pressure"),
        Channel("p_l", "Pa", "absolute actuator (load) pressure"),
        Channel("p_ls", "Pa", "absolute LS pressure at the FC spring chamber"),
        Channel("xa", "m", "actuator position"),
        Channel("va", "m/s", "actuator velocity"),
    ),
    inputs=("f_sol", "a_cv"),
    package="hydro_envs.plants.load_sensing",
    params_class="LoadSensingParams",
    envs=(
        EnvEntry(
            "hydro_envs/LoadSensing-v0",
            "hydro_envs.envs.load_sensing:LoadSensingEnv",
            "hydro_envs.envs.load_sensing:LoadSensingVectorEnv",
            2000,
        ),
    ),
    stroke_parameter="stroke",
    pressure_parameter="relief_pressure",
    dry_friction_parameters=("actuator_coulomb",),
    # assumed: the env runs at 1 kHz; coarser than 50 Hz misses the pump and compensator dynamics
    max_sample_time=0.02,
)
