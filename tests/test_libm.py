"""hydro_envs.libm: compiled exp/log give numba's math.exp/math.log numbers bit for bit.

The laws call them in the plants' right-hand sides; a routine that differed in one ulp anywhere
would change every trajectory. Compared over the whole float64 range of each function, its
overflow and underflow, subnormals, zeros, infinities and NaN.
"""

from __future__ import annotations

import math
import platform
import sys

import numba
import numpy as np
import pytest

from hydro_envs import libm


@numba.njit
def _both(x, out):
    for i in range(x.shape[0]):
        out[i, 0] = math.exp(x[i])
        out[i, 1] = libm.exp(x[i])
        out[i, 2] = math.log(x[i])
        out[i, 3] = libm.log(x[i])


def _arguments() -> np.ndarray:
    rng = np.random.default_rng(0)
    special = [0.0, -0.0, 1.0, -1.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1e-300, 0.5, 2.0, 709.78, 709.79,
               710.0, -708.4, -745.1, -745.2, -746.0, 1e300, np.inf, -np.inf, np.nan, math.e, 1.0 - 2.0**-53,
               1.0 + 2.0**-52]
    return np.concatenate([
        np.array(special),
        rng.uniform(-800.0, 800.0, 200_000),  # exp: underflow, normal, overflow
        rng.normal(0.0, 2.0, 200_000),
        np.exp(rng.uniform(-744.0, 709.0, 200_000)),  # log: subnormal to 1e308
        -np.exp(rng.uniform(-50.0, 50.0, 1_000)),  # log of negatives: NaN
        rng.uniform(0.5, 2.0, 200_000),  # log near 1
    ])


def test_compiled_exp_and_log_equal_numbas_math_to_the_bit():
    x = _arguments()
    out = np.empty((x.size, 4))
    with np.errstate(all="ignore"):
        _both(x, out)
    bits = out.view(np.int64)
    assert np.array_equal(bits[:, 0], bits[:, 1]), x[bits[:, 0] != bits[:, 1]][:5]
    # log outside its domain (x < 0): NaN from both, whose sign bit glibc's wrapper sets otherwise
    nan = np.isnan(out[:, 2])
    np.testing.assert_array_equal(np.isnan(out[:, 3]), nan)
    assert np.all(x[nan & ~np.isnan(x)] < 0.0)
    assert np.array_equal(bits[~nan, 2], bits[~nan, 3]), x[~nan][bits[~nan, 2] != bits[~nan, 3]][:5]


def test_from_python_they_are_math_exp_and_log():
    for v in (-700.0, -1.5, 0.0, 1e-3, 3.0, 700.0):
        assert libm.exp(v) == math.exp(v)
    for v in (1e-300, 0.25, 1.0, 7.0, 1e300):
        assert libm.log(v) == math.log(v)
    with pytest.raises(ValueError):
        libm.log(0.0)  # as math.log (compiled code returns -inf, as numba's math.log)


def test_other_argument_types_fall_back_to_numbas_math():
    @numba.njit
    def f(i, s):
        return libm.exp(i), libm.log(i), libm.exp(s), libm.log(s)

    e_i, l_i, e_s, l_s = f(3, np.float32(2.0))
    assert e_i == math.exp(3) and l_i == math.log(3)
    assert e_s == np.float32(math.exp(2.0)) and l_s == np.float32(math.log(2.0))


@pytest.mark.skipif(not (sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"),
                    reason="glibc's __exp_finite/__log_finite exist only on glibc")
def test_glibc_routines_are_used_on_glibc():
    assert libm.USES_GLIBC_ROUTINES


def test_without_glibcs_routines_compiled_code_calls_numbas_helpers(monkeypatch):
    monkeypatch.setattr(libm, "_glibc_routine", lambda name: None)
    try:
        assert libm._install() is False

        @numba.njit
        def both(x, out):  # compiled after the helpers were registered
            for i in range(x.shape[0]):
                out[i, 0] = math.exp(x[i])
                out[i, 1] = libm.exp(x[i])
                out[i, 2] = math.log(x[i])
                out[i, 3] = libm.log(x[i])

        x = np.abs(_arguments())
        out = np.empty((x.size, 4))
        with np.errstate(all="ignore"):
            both(x, out)
        bits = out.view(np.int64)
        assert np.array_equal(bits[:, 0], bits[:, 1]) and np.array_equal(bits[:, 2], bits[:, 3])
    finally:
        monkeypatch.undo()
        libm._install()
