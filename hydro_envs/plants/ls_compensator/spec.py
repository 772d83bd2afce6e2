"""Registry entry of the load-sensing pump flow compensator with its pilot pipe (seed 000)."""

from hydro_envs.spec import Channel, PlantSpec

SPEC = PlantSpec(
    name="ls_compensator",
    title="load-sensing pump flow compensator: spool valve fed through a pilot pipe",
    source="000_d7d5fd9bd6b165a2.txt: eqs (1)-(21), Table 1, methods 1 and 2",
    channels=(
        Channel("p1", "Pa", "absolute pressure at the pipe inlet (method 1: junction J) or inlet P (method 2: p_P)"),
        Channel("p2", "Pa", "absolute pressure in the pilot chamber at the spool end of the pipe (method 1)"),
        Channel("p_out", "Pa", "absolute pressure at the outlet port X, upstream of the calibrated orifice (method 2: p_I)"),
        Channel("x", "m", "spool travel from its seat (simulated truth; a real rig needs an LVDT)"),
        Channel("pump_speed", "rad/s", "gear-pump shaft speed (method 2; 10 teeth: ripple at 10x the shaft frequency)"),
    ),
    inputs=("p1",),
    package="hydro_envs.plants.ls_compensator",
    params_class="LSCompensatorParams",
    experiments=("run_method1", "run_method2"),
    pressure_parameter="max_pressure",
    # assumed: the 000 rigs are sampled at 10-20 kHz; coarser than 200 Hz misses the pilot pipe's waves
    max_sample_time=0.005,
)
