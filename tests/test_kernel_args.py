"""The kernel-argument unit (hydro_envs.envs.kernel_args): building, running kernels through it."""

from __future__ import annotations

import copy

import gymnasium as gym
import numba as nb
import numpy as np
import pytest
from numba.experimental import structref

import hydro_envs  # noqa: F401
from hydro_envs.envs.kernel_args import KernelArgs, KernelArgsType, define_kernel_args


@structref.register
class _DemoArgsType(KernelArgsType):
    pass


class _DemoArgs(KernelArgs):
    fields = ("x", "out", "scale")


define_kernel_args(_DemoArgs, _DemoArgsType)


@nb.njit(cache=False)
def _scaled(a):
    for i in range(a.x.shape[0]):
        a.out[i] = a.scale * a.x[i]


def test_make_names_missing_and_unknown_fields() -> None:
    with pytest.raises(ValueError, match=r"missing fields \['scale'\], unknown fields \['gain'\]"):
        _DemoArgs.make({"x": np.zeros(2), "out": np.zeros(2), "gain": 1.0})


def test_run_matches_a_direct_call_and_then_uses_the_entry_point() -> None:
    x = np.arange(5.0)
    out = np.zeros(5)
    unit = _DemoArgs.make({"x": x, "out": out, "scale": 3.0})
    direct = np.zeros(5)
    _scaled(_DemoArgs.make({"x": x, "out": direct, "scale": 3.0}))
    unit.run(_scaled)
    np.testing.assert_array_equal(out, direct)
    entry = unit.__dict__["_entries"][_scaled]
    assert entry is not _scaled  # the compiled entry point, not the dispatcher
    out[:] = 0.0
    unit.run(_scaled)  # the second call goes through the entry point
    np.testing.assert_array_equal(out, direct)


def test_a_unit_of_another_type_gets_its_own_compiled_version() -> None:
    x32 = np.arange(4, dtype=np.float32)
    out = np.zeros(4, dtype=np.float32)
    unit = _DemoArgs.make({"x": x32, "out": out, "scale": 2.0})
    unit.run(_scaled)
    unit.run(_scaled)
    np.testing.assert_array_equal(out, 2.0 * x32)


def test_a_copied_batch_builds_its_own_unit() -> None:
    env = gym.make("hydro_envs/ForceActuator-v0")
    env.reset(seed=0)
    batch = env.unwrapped._batch
    unit = batch.observe_args()
    twin = copy.deepcopy(batch)
    assert twin._kargs is None
    assert twin.observe_args() is not unit
    twin.observe()
    np.testing.assert_array_equal(twin.obs, batch.obs)


@nb.njit(cache=False)
def _scaled_block(a, lo, hi):
    for i in range(lo, hi):
        a.out[i] = a.scale * a.x[i]


def test_run_passes_integer_arguments_after_the_unit() -> None:
    out = np.zeros(6)
    unit = _DemoArgs.make({"x": np.arange(6.0), "out": out, "scale": -1.0})
    unit.run(_scaled_block, 2, 4)
    unit.run(_scaled_block, 4, 5)  # through the entry point
    np.testing.assert_array_equal(out, [0.0, 0.0, -2.0, -3.0, -4.0, 0.0])
    assert unit.__dict__["_entries"][_scaled_block] is not _scaled_block
