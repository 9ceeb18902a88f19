"""sdfphys._shared_kernel: callers call the field evaluator by name, not a copy of it.

The field program's evaluator ``sdf.compiled.run`` is called from the collision, ray
and rendering kernels through ``run_shared``: each caller calls the entry point held
in the cell the symbol names; the machine code of ``run`` exists once per process. A
caller loaded from the on-disk cache in a fresh process, before anything has compiled
or loaded ``run``, must find it published when it runs.
"""

import os
import subprocess
import sys

import numpy as np
import pytest
from numba import errors, njit

from sdfphys import sdf
from sdfphys._shared_kernel import _REGISTRY, shared
from sdfphys.collide import _mesh_contacts_kernels as mck
from sdfphys.collide import descent
from sdfphys.sdf.compiled import RUN_TYPES, compile_field, run, run_shared, scratch

SYMBOL = "sdfphys_sdf_compiled_run"
#: A box with a round bite out of it: a program of three instructions.
FIELD = {"op": "difference", "of": [{"type": "box", "size": [1.2, 0.6]},
                                    {"type": "circle", "radius": 0.2, "offset": [0.3, 0.1]}]}


def _program():
    return compile_field(sdf.field(FIELD))


def test_a_caller_computes_run_s_own_bits_and_holds_no_copy_of_it():
    program = _program()
    points = np.random.default_rng(3).uniform(-1.0, 1.0, (50, 2))
    value, grad = mck._evaluate(program.code, program.consts, program.depth,
                                program.nesting, points, len(points))
    stack, frames, cur = scratch(program.depth, program.nesting, len(points))
    ref_value, ref_grad = np.empty(len(points)), np.empty((len(points), 2))
    run(program.code, program.consts, points, len(points), stack, frames, cur,
        ref_value, ref_grad, 0, 0, 0)
    assert value.tobytes() == ref_value.tobytes() and grad.tobytes() == ref_grad.tobytes()
    record = _REGISTRY[SYMBOL]
    compiled = run.overloads[RUN_TYPES]
    assert record.published and record.cell.value == \
        compiled.library.get_pointer_to_function(compiled.fndesc.mangled_name)
    library = next(iter(mck._evaluate.overloads.values())).library
    module = library._get_module_for_linking()
    defined = [f.name for f in module.functions if not f.is_declaration]
    assert module.get_global_variable(SYMBOL).is_declaration
    assert not [name for name in defined if "8compiled3run" in name]


def test_the_shared_call_takes_only_its_signature():
    @njit
    def wrong(code, consts, points):
        stack, frames, cur = scratch(1, 1, 1)
        run_shared(code, consts, points, 1, stack, frames, cur, np.empty(1),
                   np.empty((1, 2)), 0, 0, 0)

    program = _program()
    with pytest.raises(errors.TypingError, match=SYMBOL):
        wrong(program.code, program.consts, np.zeros((1, 2), np.float32))
    with pytest.raises(ValueError, match="registered twice"):
        shared(run, RUN_TYPES, SYMBOL)


def test_the_descent_s_shared_kernels_are_published_for_their_declared_types():
    """A compiled triangle descent runs the rounds, propose and accept through their
    cells: each is published, compiled for its declared argument types and returning
    its declared type (a mismatch would be a TypeError at publication)."""
    f = sdf.field(FIELD)
    tri = np.array([[[-1.0, -1.0], [1.0, -1.0], [0.0, 1.0]]])
    point, value = descent.triangle_deepest(f, tri)
    assert value.shape[0] == 1 and np.isfinite(value).all()
    for symbol in ("sdfphys_collide_descent_rounds", "sdfphys_collide_descent_propose",
                   "sdfphys_collide_descent_accept"):
        record = _REGISTRY[symbol]
        compiled = record.kernel.overloads[record.argtypes]
        assert record.published and compiled.signature.return_type == record.restype
        assert record.cell.value == compiled.library.get_pointer_to_function(
            compiled.fndesc.mangled_name)


SCRIPT = """
import numpy as np
from sdfphys import sdf
from sdfphys._shared_kernel import _REGISTRY
from sdfphys.collide import _mesh_contacts_kernels as mck
from sdfphys.sdf.compiled import compile_field, run
p = compile_field(sdf.field(%r))
points = np.random.default_rng(3).uniform(-1.0, 1.0, (50, 2))
assert not _REGISTRY["sdfphys_sdf_compiled_run"].published and not run.overloads
value, grad = mck._evaluate(p.code, p.consts, p.depth, p.nesting, points, len(points))
k = mck._evaluate
print(sum(k.stats.cache_hits.values()), sum(k.stats.cache_misses.values()))
print(value.tobytes().hex()[:64], grad.tobytes().hex()[:64], float(value.sum()))
"""


@pytest.mark.slow        # two fresh processes on a fresh cache: about 10 s
def test_a_cached_caller_in_a_fresh_process_finds_the_kernel_published(tmp_path):
    """Two processes on one fresh cache, each calling the caller before anything else:
    the first compiles it, the second loads its machine code, whose call through the
    cell must reach ``run`` (published before the caller runs; before it, a call
    raises numba's unresolved-symbol error)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))

    def once():
        done = subprocess.run([sys.executable, "-c", SCRIPT % (FIELD,)], env=env,
                              capture_output=True, text=True, cwd=tmp_path)
        assert done.returncode == 0, done.stderr[-2000:]
        counts, bits = done.stdout.split("\n", 1)
        return tuple(map(int, counts.split())), bits

    first_counts, first_bits = once()
    second_counts, second_bits = once()
    assert first_counts == (0, 1) and second_counts == (1, 0)
    assert second_bits == first_bits
