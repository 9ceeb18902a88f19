"""Numba's compiler flags in closed form (``sdfphys._numba_flags``): numba's values,
hashes and equalities, for flags as numba's compiler makes them."""

from __future__ import annotations

from numba.core import compiler, targetconfig

import sdfphys  # noqa: F401  (installs the methods)
from sdfphys import _numba_flags


def _numba_values(flags):
    """``TargetConfig.values`` as numba writes it: every option through its property."""
    return {name: getattr(flags, name) for name in flags.options}


def _cases():
    plain = compiler.Flags()
    nopython = compiler.Flags()
    nopython.nrt = True
    nopython.no_cfunc_wrapper = True
    nopython.error_model = "numpy"
    default_set = compiler.Flags()
    default_set.nrt = compiler.Flags.options["nrt"].default        # set to its default
    copied = compiler.Flags(copy_from=nopython)
    discarded = compiler.Flags(copy_from=nopython)
    discarded.discard("error_model")
    return [plain, nopython, default_set, copied, discarded]


def test_the_flags_methods_are_installed_and_install_is_idempotent():
    assert targetconfig.TargetConfig.values is _numba_flags.values
    _numba_flags.install()
    assert targetconfig.TargetConfig.__hash__ is _numba_flags.config_hash


def test_values_hashes_and_equalities_are_numba_s():
    cases = _cases()
    for a in cases:
        assert a.values() == _numba_values(a)
        assert hash(a) == hash(tuple(sorted(_numba_values(a))))
        for b in cases:
            assert (a == b) == (_numba_values(a) == _numba_values(b))
    plain, nopython, default_set, copied, discarded = cases
    assert plain == default_set and nopython == copied and nopython != plain
    assert discarded != nopython and discarded.error_model == "python"
    assert {nopython: 1}[copied] == 1 and (plain == 3) is False
