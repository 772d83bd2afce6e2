"""Every registered plant gives the typed contract (:mod:`hydro_envs.contract`), and a broken
contract is reported with the plant and the piece named.

The per-plant checks (:func:`hydro_envs.contract.conformance_problems`): a ``PlantModel`` and a
``KernelSet``, outputs that are registry channels and valid state indices, a finite rest state
of the right length, parameter rows as wide as the dataclass' columns, finite stiffness modes,
and one kernel step from rest that stays finite. Here also: the module constants the envs read
(``N_STATES``, ``STATE_NAMES``, ``N_PARAMS``) agree with the contract, the column indices are
the dataclass' own, and the kernels are the factory's (:func:`hydro_envs.sim.binding.bind_rk4`).
"""

from __future__ import annotations

import dataclasses
import sys
import types

import numpy as np
import pytest

from hydro_envs import registry
from hydro_envs.contract import KernelSet, PlantModel, conformance_problems, param_columns
from hydro_envs.spec import Channel, PlantSpec

MODEL_PLANTS = [s.name for s in registry.specs(with_model=True)]


def test_every_plant_with_a_model_is_checked():
    assert len(MODEL_PLANTS) >= 8
    assert "servo_cylinder" in MODEL_PLANTS and "differential_cylinder" in MODEL_PLANTS
    assert "seal_friction" not in MODEL_PLANTS  # measured data only


@pytest.mark.parametrize("plant", MODEL_PLANTS)
def test_plant_conforms_to_the_contract(plant):
    problems = conformance_problems(registry.get(plant))
    assert problems == [], "\n".join(problems)


@pytest.mark.parametrize("plant", MODEL_PLANTS)
def test_module_constants_agree_with_the_contract(plant):
    spec = registry.get(plant)
    c, model, params = spec.contract, spec.model, spec.module("params")
    assert isinstance(c, PlantModel) and model.CONTRACT is c
    assert tuple(model.STATE_NAMES) == c.state_names and model.N_STATES == c.n_states, plant
    assert spec.state_names == c.state_names and spec.n_states == c.n_states
    cols = param_columns(spec.params_cls)
    assert list(cols) == [f.name for f in dataclasses.fields(spec.params_cls)] + list(spec.params_cls.derived_names)
    assert params.N_PARAMS == len(cols) == spec.params_cls().to_array().shape[0], plant
    # every I_* / D_* column index of the params module points at a distinct column
    idx = {k: v for k, v in vars(params).items() if k[:2] in ("I_", "D_") and isinstance(v, int)}
    assert idx and len(set(idx.values())) == len(idx) and max(idx.values()) < len(cols), plant
    fields = len(dataclasses.fields(spec.params_cls))
    assert {v for v in idx.values() if v < fields} == set(range(fields)), f"{plant}: a field has no I_ index"


@pytest.mark.parametrize("plant", MODEL_PLANTS)
def test_kernels_are_made_by_the_one_factory(plant):
    spec = registry.get(plant)
    k, module = spec.kernels, spec.module("kernels")
    assert isinstance(k, KernelSet)
    for name in ("step_serial", "step_parallel", "trajectories", "derivatives"):
        fn = getattr(k, name)
        assert fn.py_func.__qualname__ == f"{plant}.{name}", (plant, name, fn.py_func.__qualname__)
        assert fn.py_func.__code__.co_filename.endswith("binding.py")
        assert getattr(module, name) is fn, f"{plant}: kernels.{name} is not KERNELS.{name}"
    assert k.rhs is module.rhs and k.guard is module.guard
    picked = k.pick(spec.params_cls().to_array()[None, :])
    assert isinstance(picked, KernelSet)


def test_rodless_parameter_specialised_kernels_are_kernel_sets():
    from hydro_envs.plants.rodless_cylinder import kernels

    spec = registry.get("rodless_cylinder")
    assert spec.kernels.for_params is kernels.for_params
    P = spec.params_cls().to_array()[None, :]
    assert spec.kernels.pick(P).step_serial is kernels.step_serial_stiff_supply_lugre
    names = {ks.step_serial.py_func.__qualname__ for ks in kernels._KERNELS.values()}
    assert len(names) == 4  # four distinct cache keys


def test_param_columns_follow_the_field_order_and_the_derived_names():
    @dataclasses.dataclass(frozen=True)
    class Toy:
        b: float = 1.0
        a: float = 2.0
        derived_names = ("c",)

    assert param_columns(Toy) == {"b": 0, "a": 1, "c": 2}
    with pytest.raises(TypeError, match="not a dataclass"):
        param_columns(int)


# ------------------------------------------------------------------ broken contracts are named
def _servo_like(**changes):
    """A stand-in spec: the servo cylinder's pieces with ``changes`` (contract fields, or the
    spec attributes ``kernels`` / ``contract``)."""
    spec = registry.get("servo_cylinder")
    kernels = changes.pop("kernels", spec.kernels)
    contract = changes.pop("contract", None)
    if contract is None:
        contract = dataclasses.replace(spec.contract, **changes)
    return types.SimpleNamespace(name="broken_servo", contract=contract, kernels=kernels, params_cls=spec.params_cls,
                                 channels=spec.channels, inputs=spec.inputs)


def _one(problems, *words):
    assert len(problems) == 1, problems
    for w in ("broken_servo",) + words:
        assert w in problems[0], (w, problems[0])


def test_a_rest_state_of_the_wrong_length_is_named():
    _one(conformance_problems(_servo_like(rest_state_from_measurement=lambda p, m: np.zeros(3))), "rest_state", "(3,)",
         "(7,)")


def test_a_rest_state_that_is_not_finite_is_named():
    _one(conformance_problems(_servo_like(rest_state_from_measurement=lambda p, m: np.full(7, np.nan))), "rest_state",
         "finite=False")


def test_a_missing_rest_state_is_named():
    _one(conformance_problems(_servo_like(rest_state=None, rest_state_from_measurement=None)), "rest_state")


def test_an_output_that_is_not_a_channel_is_named():
    _one(conformance_problems(_servo_like(state_outputs={"x": 0, "q9": 1})), "output 'q9'")


def test_non_finite_stiffness_modes_are_named():
    _one(conformance_problems(_servo_like(stiffness_modes=lambda p: {"valve": float("nan")})), "stiffness_modes")


def test_a_kernel_step_that_blows_up_is_named():
    spec = registry.get("servo_cylinder")

    def step_nan(Y, U, P, dt, NSUB, W, clamps):
        Y[:] = np.nan

    broken = dataclasses.replace(spec.kernels, step_serial=step_nan)
    _one(conformance_problems(_servo_like(kernels=broken)), "kernel step", "not finite")


def test_a_kernel_set_of_the_wrong_type_is_named():
    _one(conformance_problems(_servo_like(kernels=types.SimpleNamespace())), "KERNELS", "not a KernelSet")


def test_a_contract_of_the_wrong_type_is_named():
    _one(conformance_problems(_servo_like(contract=object())), "CONTRACT", "not a PlantModel")


@pytest.mark.parametrize("field, value, words", [
    ("state_units", ("m",), "state_units"),
    ("state_outputs", {"x": 7}, "state_outputs['x'] = 7"),
    ("derivative_outputs", {"a": -1}, "derivative_outputs['a'] = -1"),
    ("fit_outputs", ["x"], "fit_outputs"),
    ("rest_state", 3.0, "rest_state must be callable"),
    ("soak_temperatures", lambda Y, P: Y, "soak_temperature_floor"),
])
def test_plant_model_refuses_a_wrong_field_by_name(field, value, words):
    c = registry.get("servo_cylinder").contract
    with pytest.raises((TypeError, ValueError), match=words.replace("[", r"\[").replace("]", r"\]")):
        dataclasses.replace(c, **{field: value})


def test_a_model_module_without_contract_is_named(monkeypatch):
    model = types.ModuleType("contract_test_plant.model")
    model.STATE_NAMES = ("x",)  # the old implicit attributes are not enough
    monkeypatch.setitem(sys.modules, "contract_test_plant.model", model)
    spec = PlantSpec(name="contract_test_plant", title="t", source="t", channels=(Channel("x", "m", "x"),),
                     package="contract_test_plant", params_class="P")
    with pytest.raises(TypeError, match="contract_test_plant.*CONTRACT.*PlantModel"):
        spec.contract
    with pytest.raises(TypeError, match="contract_test_plant.*CONTRACT"):
        spec.state_names


# ------------------------------------------------------------------ the factory's arithmetic
def _hand_written_slider_step():
    """The slider's serial step as a hand-written module-level kernel was before the factory."""
    import numba as nb

    from hydro_envs.plants.slider.model import slider_guard, slider_rhs
    from hydro_envs.sim.rk4 import rk4_advance

    @nb.njit(error_model="numpy", _nrt=False)
    def step_serial(Y, U, P, dt, NSUB, W, clamps):
        for i in range(Y.shape[0]):
            clamps[i] += rk4_advance(slider_rhs, slider_guard, Y[i], U[i], P[i], dt / NSUB[i], NSUB[i], W[i])

    return step_serial


def test_the_factory_kernel_is_bit_identical_to_a_hand_written_one():
    spec = registry.get("slider")
    p = spec.params_cls()
    rng = np.random.default_rng(0)
    Y0 = np.stack([spec.contract.rest_state(p)] * 3) + rng.normal(0.0, 1e-4, (3, spec.n_states))
    P = np.stack([p.to_array()] * 3)
    NSUB = np.array([1, 3, 7], dtype=np.int64)
    runs = []
    for step in (spec.kernels.step_serial, _hand_written_slider_step()):
        Y, W, c = Y0.copy(), np.zeros((3, 5, spec.n_states)), np.zeros(3, dtype=np.int64)
        for k in range(200):
            step(Y, np.full((3, 1), 30.0 * np.sin(0.05 * k)), P, 1e-3, NSUB, W, c)
        runs.append((Y, c))
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])
    assert not np.array_equal(runs[0][0], Y0)  # it moved


def test_an_unknown_preset_is_named():
    spec = registry.get("shaking_table")
    broken = types.SimpleNamespace(name="broken_table", contract=dataclasses.replace(spec.contract, presets=("nope",)),
                                   kernels=spec.kernels, params_cls=spec.params_cls, channels=spec.channels,
                                   inputs=spec.inputs)
    problems = conformance_problems(broken, run_kernels=False)
    assert len(problems) == 1 and "broken_table" in problems[0] and "preset('nope')" in problems[0], problems


def test_the_friction_command_takes_its_plants_and_tests_from_the_registry():
    from identification.cli import _friction_tests

    assert _friction_tests() == {"servo_cylinder": "annulus", "seal_friction": "strokes",
                                 "differential_cylinder": "two_areas"}
    with pytest.raises(ValueError, match="friction_test = 'square'"):
        PlantSpec(name="p", title="t", source="s", channels=(Channel("x", "m", "x"),), friction_test="square")
