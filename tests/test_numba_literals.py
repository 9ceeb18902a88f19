"""``sdfphys._numba_literals``: a package kernel called with a constant and with a variable
compiles once; a kernel whose typing needs the constant still compiles; functions outside
the package keep numba's literal dispatch."""

from __future__ import annotations

from numba import njit, types

import sdfphys  # noqa: F401  (installs the call-template hook)


def _jit_in(module: str, function):
    """``function`` jitted as if defined in ``module`` (no cache)."""
    function.__module__ = module
    return njit(cache=False)(function)


def _callers(callee):
    """Two kernels calling ``callee`` with the constant 3 and with a variable."""

    @njit(cache=False)
    def with_constant(x):
        return callee(x, 3)

    @njit(cache=False)
    def with_variable(x, k):
        return callee(x, k)

    return with_constant, with_variable


def _scale(x, k):
    return x * k


def test_a_package_kernel_compiles_once_for_constants_and_variables():
    callee = _jit_in("sdfphys._probe", _scale)
    with_constant, with_variable = _callers(callee)
    assert with_constant(2.0) == 6.0
    assert with_variable(2.0, 4) == 8.0
    assert len(callee.signatures) == 1
    assert all(not isinstance(t, types.Literal) for t in callee.signatures[0])


def test_outside_the_package_numba_keeps_a_literal_specialisation():
    callee = _jit_in("elsewhere._probe", _scale)
    with_constant, with_variable = _callers(callee)
    assert with_constant(2.0) == 6.0
    assert with_variable(2.0, 4) == 8.0
    assert len(callee.signatures) == 2
    assert any(isinstance(t, types.Literal) for s in callee.signatures for t in s)


def _item(t, i):
    return t[i]


def test_a_kernel_that_needs_the_constant_falls_back_to_it():
    """A heterogeneous tuple can only be indexed by a constant: the plain int64 fails to
    type, and the call is compiled for the literal as numba would."""
    item = _jit_in("sdfphys._probe", _item)

    @njit(cache=False)
    def second():
        return item((1, 2.5), 1)

    assert second() == 2.5
    assert any(isinstance(t, types.Literal) for s in item.signatures for t in s)
