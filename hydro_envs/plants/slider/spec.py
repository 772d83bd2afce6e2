"""Registry entry of the generic force-driven slider (rigid axis: mass, friction, offset)."""

from hydro_envs.spec import Channel, PlantSpec

SPEC = PlantSpec(
    name="slider",
    title="force-driven rigid axis: mass, Stribeck friction, force offset, end stops",
    source="002 eq (1) friction on a generic stage (identification plant)",
    channels=(
        Channel("f", "N", "applied force on the slider (positive towards +x)"),
        Channel("x", "m", "slider position from the lower end stop (0..stroke)"),
    ),
    inputs=("f",),
    package="hydro_envs.plants.slider",
    params_class="SliderParams",
    stroke_parameter="stroke",
    # assumed: a rigid axis recorded at 20 Hz or faster (EMPS: 1 kHz), driven by at most 1 MN
    max_sample_time=0.05,
    max_force=1e6,
)
