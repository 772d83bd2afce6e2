"""Registry entry of the high-bandwidth force actuator (seed 001)."""

from hydro_envs.spec import Channel, EnvEntry, PlantSpec

SPEC = PlantSpec(
    name="force_actuator",
    title="high-bandwidth force actuator: jet-pipe valve on the piston, U-shaped force sensor",
    source="001_3253c61f41166c3e.txt: eqs (1)-(8), Table 1, sec. 4.7",
    channels=(
        Channel("i", "A", "valve current command (zero-order held)"),
        Channel("f", "N", "sensed force F_s = k_s x_s (positive: piston pushing out)"),
    ),
    inputs=("i",),
    package="hydro_envs.plants.force_actuator",
    params_class="ForceActuatorParams",
    envs=(
        EnvEntry(
            "hydro_envs/ForceActuator-v0",
            "hydro_envs.envs.force_actuator:ForceActuatorEnv",
            "hydro_envs.envs.force_actuator:ForceActuatorVectorEnv",
            5000,
        ),
        EnvEntry(
            "hydro_envs/ForceActuatorSmallForce-v0",
            "hydro_envs.envs.force_actuator:ForceActuatorSmallForceEnv",
            "hydro_envs.envs.force_actuator:ForceActuatorSmallForceVectorEnv",
            5000,
        ),
    ),
    experiments=("proportional_loop", "closed_loop_frequency_response", "limit_cycle_sweep", "sensor_ring_down"),
    stroke_parameter="stroke",
    pressure_parameter="supply_pressure",
    # assumed: 001 identifies at 5 kHz (sec. 4.5); coarser than 200 Hz misses its 150 Hz sines
    max_sample_time=0.005,
    # 001 eq (1) / Table 2: the Coulomb and both static levels (no viscous seal friction; eq (5)'s
    # hydraulic damping is not friction)
    dry_friction_parameters=("coulomb_friction", "stiction_retract", "stiction_extend"),
)
