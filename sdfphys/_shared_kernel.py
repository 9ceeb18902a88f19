"""A kernel every caller calls by name, its machine code built once per process.

Numba builds a kernel into every kernel that calls it: the caller's library links the
callee's LLVM module, optimises the whole again and emits machine code for all of it.
The field program's evaluator ``sdf.compiled.run`` (with the primitive kernels it
calls, 18 functions) was built into 13-16 libraries of a cold showcase run, each copy
optimised and emitted anew: about 0.8 s of LLVM a copy, the largest share of the
compilations that a cold start repeats.

``shared(kernel, argtypes, symbol)`` returns a function to call from njit code in
place of ``kernel``. A caller compiled with it loads the kernel's entry point from an
external cell named ``symbol`` and calls it with numba's calling convention for
``argtypes``; nothing of the kernel enters the caller's library. The cell is a
pointer this module owns, published under the symbol in the process's symbol table
at import (``llvmlite.binding.add_symbol``, how numba resolves its own runtime), so a
library naming it always links; a caller's cached machine code names the symbol, not
an address, and stays valid across processes. The cell holds numba's
``nrt_unresolved_abort`` (a call raises RuntimeError) until the kernel is published:
compiled or loaded for ``argtypes``, its native entry stored in the cell, once per
process, when the outermost compilation that finalised a library using the cell
returns (``install`` wraps ``CPUCodeLibrary._finalize_final_module``, which sees the
cell named in a fresh or a cached library's module, and ``Dispatcher.compile``), so
before any such library can run; a caller compiles without waiting for the kernel.
A caller's cache stamp covers the kernel's module, which it imports (``_numba_cache``):
an edit of the kernel recompiles its callers as before.

The call is an ordinary call (the arguments' types must be the signature's, constants
of its types are accepted; the kernel's result is returned as numba returns it, a new
reference), the results are the kernel's own bits. Only njit code calls it; Python
calls the kernel.
"""

from __future__ import annotations

import ctypes
from typing import Any

import llvmlite.binding as ll
from llvmlite import ir
from numba import types
from numba.core import cgutils, codegen, dispatcher, errors
from numba.core.runtime import rtsys
from numba.core.typing import signature as make_signature
from numba.extending import intrinsic

__all__ = ["F1", "F2", "F3", "I1", "I2", "install", "shared"]

#: Shorthands for shared signatures: C-contiguous float64 arrays of 1, 2, 3 dimensions
#: and int64 arrays of 1, 2.
F1, F2, F3 = types.float64[::1], types.float64[:, ::1], types.float64[:, :, ::1]
I1, I2 = types.int64[::1], types.int64[:, ::1]

#: Symbol -> the shared kernel's record, for every ``shared`` call in the package.
_REGISTRY: dict[str, _Shared] = {}

#: Numba's ``CPUCodeLibrary._finalize_final_module`` and ``Dispatcher.compile`` (as
#: installed before this module's ``install``), wrapped by ``_finalize`` and ``_compile``.
_NUMBA_FINALIZE = codegen.CPUCodeLibrary._finalize_final_module
_NUMBA_COMPILE = dispatcher.Dispatcher.compile

#: Nested ``Dispatcher.compile`` calls under way in this process (numba compiles under
#: one process-wide lock, one thread at a time).
_depth = 0


class _Shared:
    """One shared kernel: its dispatcher, argument types, symbol and the cell the
    symbol names (the address of the kernel's native entry once published)."""

    def __init__(self, kernel: Any, argtypes: tuple, restype: Any, symbol: str):
        self.kernel = kernel
        self.argtypes = argtypes
        self.restype = restype
        self.symbol = symbol
        self.cell = ctypes.c_void_p(0)
        ll.add_symbol(symbol, ctypes.addressof(self.cell))
        self.wanted = False
        self.published = False

    def publish(self) -> None:
        """Compile (or load) the kernel for its signature and put its native entry in
        the cell (once per process)."""
        if self.published:
            return
        self.published = True                   # compiling it calls _compile again
        try:
            self.kernel.compile(self.argtypes)
            result = self.kernel.overloads[self.argtypes]
            if result.signature.return_type != self.restype:
                raise TypeError(f"{self.symbol}: returns {result.signature.return_type}, "
                                f"not {self.restype}")
            address = result.library.get_pointer_to_function(result.fndesc.mangled_name)
            if not address:
                raise RuntimeError(f"{self.symbol}: no native entry compiled")
        except BaseException:
            self.published = False
            raise
        self.cell.value = address


def shared(kernel: Any, argtypes: tuple, symbol: str, restype: Any = types.none):
    """A function that njit code calls in place of ``kernel`` (a dispatcher), through
    the cell named ``symbol`` (unique in the process) with the argument types
    ``argtypes`` and the return type ``restype`` (numba types)."""
    if symbol in _REGISTRY:
        raise ValueError(f"shared kernel symbol {symbol!r} registered twice")
    record = _REGISTRY[symbol] = _Shared(kernel, tuple(argtypes), restype, symbol)

    @intrinsic
    def call(typingctx, *args):
        if len(args) != len(record.argtypes) or any(
                types.unliteral(a) != t for a, t in zip(args, record.argtypes)):
            raise errors.TypingError(
                f"{symbol}: arguments {args} are not the shared signature {record.argtypes}")

        def lower(context, builder, sig, packed):
            values = cgutils.unpack_tuple(builder, packed[0], len(args))
            values = [context.cast(builder, v, a, t)
                      for v, a, t in zip(values, args, record.argtypes)]
            fnty = context.call_conv.get_function_type(record.restype, record.argtypes)
            try:
                cell = builder.module.get_global(symbol)
            except KeyError:
                cell = ir.GlobalVariable(builder.module, ir.IntType(8).as_pointer(), symbol)
                cell.linkage = "external"
            entry = builder.bitcast(builder.load(cell), fnty.as_pointer())
            status, result = context.call_conv.call_function(
                builder, entry, record.restype, record.argtypes, values)
            with cgutils.if_unlikely(builder, status.is_error):
                context.call_conv.return_status_propagate(builder, status)
            return result                       # a new reference, as the kernel returns it

        # numba hands an intrinsic's *args to the lowering as one tuple
        return make_signature(record.restype, types.StarArgTuple.from_types(args)), lower

    return call


def _finalize(self) -> None:
    """``_finalize_final_module``, noting the shared kernels the library calls (a cached
    library names their cells in its linking module)."""
    module = self._shared_module if self._shared_module is not None else self._final_module
    for symbol, record in _REGISTRY.items():
        if record.published or record.wanted:
            continue
        try:
            module.get_global_variable(symbol)
        except NameError:
            continue
        record.wanted = True
        if not record.cell.value:
            record.cell.value = rtsys.library.get_pointer_to_function("nrt_unresolved_abort")
    _NUMBA_FINALIZE(self)


def _compile(self, sig):
    """``Dispatcher.compile``; when the outermost compilation is done, the shared
    kernels its libraries call are published (before any of them can run)."""
    global _depth
    _depth += 1
    try:
        result = _NUMBA_COMPILE(self, sig)
    finally:
        _depth -= 1
    if _depth == 0:
        for record in _REGISTRY.values():
            if record.wanted and not record.published:
                record.publish()
    return result


def install() -> None:
    """Route numba's library finalisation and compilation through ``_finalize`` and
    ``_compile`` (idempotent; after ``_compile_lock.install``)."""
    global _NUMBA_COMPILE
    codegen.CPUCodeLibrary._finalize_final_module = _finalize
    if dispatcher.Dispatcher.compile is not _compile:
        _NUMBA_COMPILE = dispatcher.Dispatcher.compile
        dispatcher.Dispatcher.compile = _compile
