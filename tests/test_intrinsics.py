"""The compiled CPU-instruction intrinsics: prefetching changes no result, pause loops run."""

from __future__ import annotations

import platform

import numba
import numpy as np
import pytest

from hydro_envs.intrinsics import prefetch_row_element


@numba.njit(cache=True)
def _sum_with_prefetch(a, ahead):
    s = 0.0
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            prefetch_row_element(a, i, min(j + ahead, a.shape[1] - 1))
            s += a[i, j]
    return s


def test_prefetch_changes_no_value_and_takes_only_a_two_dimensional_array():
    a = np.random.default_rng(0).normal(size=(37, 101))
    assert _sum_with_prefetch(a, 8) == pytest.approx(a.sum(), rel=1e-12)
    assert _sum_with_prefetch(np.asfortranarray(a), 8) == pytest.approx(a.sum(), rel=1e-12)
    with pytest.raises(numba.core.errors.TypingError):
        numba.njit(lambda v: prefetch_row_element(v, 0, 0))(np.zeros(3))


@pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"), reason="x86 pause")
def test_pause_latency_is_measured_in_nanoseconds():
    from hydro_envs._spin import pause_ns

    ns = pause_ns(pauses=2000, repeats=3)
    assert 0.1 < ns < 1000.0
