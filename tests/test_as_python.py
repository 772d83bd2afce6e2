"""hydro_envs.jit.as_python: a compiled law's plain Python twin computes the same and compiles nothing."""

import math

import numba

from hydro_envs.jit import as_python


@numba.njit(cache=False)
def _inner(x):
    return math.exp(-x * x)


@numba.njit(cache=False)
def _outer(x, n):
    s = 0.0
    for i in range(n):
        s += _inner(x + i)
    return s


def test_twin_matches_the_compiled_function_and_compiles_nothing():
    twin = as_python(_outer)
    expected = sum(math.exp(-(0.3 + i) ** 2) for i in range(5))  # the arithmetic written out
    assert twin(0.3, 5) == expected
    assert _outer.signatures == [] and _inner.signatures == []  # f.py_func alone would have compiled _inner
    assert twin.__globals__["_inner"] is as_python(_inner)
    assert as_python(_outer) is twin  # memoised
    assert _outer(0.3, 5) == expected  # the compiled function gives the same numbers


def test_plain_function_is_returned_as_is():
    assert as_python(math.exp) is math.exp
