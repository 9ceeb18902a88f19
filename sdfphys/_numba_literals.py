"""One compilation per kernel and argument types, whatever constants its callers pass.

When an njit function calls another with a constant argument (``run(..., 0, ...)``,
``_solve(..., True)``), numba types that argument as a literal (``Literal[int](0)``,
``Literal[bool](True)``) and compiles the callee once for it, apart from the compilation
for a variable of the same type: every constant a kernel is called with from compiled
code is one more full compilation of that kernel and of whatever it calls in turn (the
field program's evaluator ``sdf.compiled.run`` is called with ``0`` by some kernels and
with a variable by others; the solver's ``_solve`` with ``True`` and ``False``).

``install`` makes a call from compiled code to a function of this package compile for
the arguments' plain types (``numba.types.unliteral``): the call with a constant then
uses the same machine code as the call with a variable. A function whose typing needs
the constant (a literal-only branch, ``literal_unroll``, a heterogeneous tuple indexed
by it) fails to type for the plain types; that call then falls back to numba's literal
dispatch, so nothing that compiled before stops compiling. Functions outside the
package keep numba's behaviour. No kernel here asks for literal dispatch
(``numba.literally``).

The results are the same bits: a literal argument only lets numba specialise the
callee's code for that value (LLVM still folds the constant where it inlines the call).
"""

from __future__ import annotations

from numba.core import dispatcher, errors, types

__all__ = ["install"]

#: Numba's method that compiles (if needed) and returns a call template for argument
#: types; wrapped by ``_plain_call_template``.
_NUMBA_CALL_TEMPLATE = dispatcher._DispatcherBase.get_call_template

#: The package whose functions compile for plain argument types.
_PACKAGE = __name__.split(".")[0]


def _plain_call_template(self, args, kws):
    """``get_call_template`` for the unliteral argument types of this package's functions
    (the literal ones when the plain types do not type the function)."""
    module = getattr(self.py_func, "__module__", "") or ""
    if module.split(".")[0] != _PACKAGE:
        return _NUMBA_CALL_TEMPLATE(self, args, kws)
    plain = tuple(types.unliteral(a) for a in args)
    plain_kws = {k: types.unliteral(v) for k, v in kws.items()}
    if plain == tuple(args) and plain_kws == kws:
        return _NUMBA_CALL_TEMPLATE(self, args, kws)
    try:
        return _NUMBA_CALL_TEMPLATE(self, plain, plain_kws)
    except errors.TypingError:
        return _NUMBA_CALL_TEMPLATE(self, args, kws)


def install() -> None:
    """Route numba's call templates through ``_plain_call_template`` (idempotent)."""
    dispatcher._DispatcherBase.get_call_template = _plain_call_template
