"""A kernel every caller calls by name, its machine code built once per process.

Numba builds a kernel into every kernel that calls it: the caller's library links the
callee's LLVM module, optimises the whole again and emits machine code for all of it.
The field program's evaluator ``sdf.compiled.run`` (with the primitive kernels it
calls, 18 functions) was built into 13-16 libraries of a cold showcase run, each copy
optimised and emitted anew: about 0.8 s of LLVM a copy, the largest share of the
compilations that a cold start repeats.

``shared(kernel, signature, symbol)`` returns a function to call from njit code in
place of ``kernel``. A caller compiled with it declares ``symbol`` as an external
function with numba's calling convention for ``signature`` and calls it; nothing of
the kernel enters the caller's library. The symbol is resolved the way numba resolves
its own runtime (``llvmlite.binding.add_symbol``, the process's symbol table), to the
native entry of ``kernel`` compiled for ``signature``: once per process, before the
first library that declares it is handed to the JIT (``install`` wraps numba's
``CPUCodeLibrary._finalize_final_module``; a library loaded from the on-disk cache
declares it in its linking module just as a freshly compiled one does). A caller's
cached machine code therefore stays valid across processes: it names the symbol, not
an address. Its cache stamp covers the kernel's module, which the caller imports
(``_numba_cache``), so an edit of the kernel recompiles its callers as before.

The call is an ordinary call (the arguments' types must be the signature's, constants
of its types are accepted), the results are the kernel's own bits. Only njit code
calls it; Python calls the kernel.
"""

from __future__ import annotations

from typing import Any

import llvmlite.binding as ll
from numba import types
from numba.core import cgutils, codegen, errors
from numba.core.typing import signature as make_signature
from numba.extending import intrinsic

__all__ = ["install", "shared"]

#: Symbol -> the shared kernel's record, for every ``shared`` call in the package.
_REGISTRY: dict[str, _Shared] = {}

#: Numba's ``CPUCodeLibrary._finalize_final_module``, wrapped by ``_finalize``.
_NUMBA_FINALIZE = codegen.CPUCodeLibrary._finalize_final_module


class _Shared:
    """One shared kernel: its dispatcher, argument types and symbol."""

    def __init__(self, kernel: Any, argtypes: tuple, symbol: str):
        self.kernel = kernel
        self.argtypes = argtypes
        self.symbol = symbol
        self.address = 0

    def ensure(self) -> None:
        """Compile (or load) the kernel for its signature and publish its native entry
        under the symbol (once per process)."""
        if self.address:
            return
        self.kernel.compile(self.argtypes)
        result = self.kernel.overloads[self.argtypes]
        address = result.library.get_pointer_to_function(result.fndesc.mangled_name)
        if not address:
            raise RuntimeError(f"{self.symbol}: no native entry compiled")
        ll.add_symbol(self.symbol, address)
        self.address = address


def shared(kernel: Any, argtypes: tuple, symbol: str):
    """A function that njit code calls in place of ``kernel`` (a dispatcher returning
    None), through ``symbol`` (unique in the process) with the argument types
    ``argtypes`` (numba types)."""
    if symbol in _REGISTRY:
        raise ValueError(f"shared kernel symbol {symbol!r} registered twice")
    record = _REGISTRY[symbol] = _Shared(kernel, tuple(argtypes), symbol)

    @intrinsic
    def call(typingctx, *args):
        if len(args) != len(record.argtypes) or any(
                types.unliteral(a) != t for a, t in zip(args, record.argtypes)):
            raise errors.TypingError(
                f"{symbol}: arguments {args} are not the shared signature {record.argtypes}")

        def lower(context, builder, sig, packed):
            record.ensure()
            values = cgutils.unpack_tuple(builder, packed[0], len(args))
            values = [context.cast(builder, v, a, t)
                      for v, a, t in zip(values, args, record.argtypes)]
            fnty = context.call_conv.get_function_type(types.none, record.argtypes)
            fn = cgutils.get_or_insert_function(builder.module, fnty, symbol)
            status, _ = context.call_conv.call_function(
                builder, fn, types.none, record.argtypes, values)
            with cgutils.if_unlikely(builder, status.is_error):
                context.call_conv.return_status_propagate(builder, status)
            return context.get_dummy_value()

        # numba hands an intrinsic's *args to the lowering as one tuple
        return make_signature(types.none, types.StarArgTuple.from_types(args)), lower

    return call


def _finalize(self) -> None:
    """``_finalize_final_module``, after publishing every shared kernel the library
    declares (a cached library declares them in its linking module)."""
    module = self._shared_module if self._shared_module is not None else self._final_module
    for symbol, record in _REGISTRY.items():
        if not record.address:
            try:
                module.get_function(symbol)
            except NameError:
                continue
            record.ensure()
    _NUMBA_FINALIZE(self)


def install() -> None:
    """Route numba's library finalisation through ``_finalize`` (idempotent)."""
    codegen.CPUCodeLibrary._finalize_final_module = _finalize
