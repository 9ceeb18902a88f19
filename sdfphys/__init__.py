"""sdfphys: a 2D rigid-body physics sandbox whose collision core is signed distance fields.

``import sdfphys`` never imports pygame: drawing, video and the interactive
window live in ``sdfphys.render``, ``sdfphys.video`` and ``sdfphys.play``.
"""

from importlib import metadata as _metadata

from . import _compile_lock, _heap, _numba_cache, _numba_flags, _numba_literals, _shared_kernel

try:
    __version__ = _metadata.version("sdfphys")      # pyproject.toml's, once installed
except _metadata.PackageNotFoundError:              # a source tree that was never installed
    __version__ = "0+unknown"

_numba_cache.install()      # before any kernel is defined: caches follow the whole package
_numba_literals.install()   # one compilation per kernel and types, constants or not
_numba_flags.install()      # compiler flags compared in closed form (the same keys)
_compile_lock.install()     # processes on one cache compile each kernel once
_shared_kernel.install()    # kernels called by name are published before their callers run
_heap.install()             # a step's large arrays reuse the heap (no page faults each step)

from . import sdf  # noqa: E402
from . import collide  # noqa: E402  (the subpackage, callable: collide.collide)
from .collide import Contacts  # noqa: E402
from .errors import SpecError  # noqa: E402
from .scene import load_scene, read_scene  # noqa: E402
from .settings import Settings, preset  # noqa: E402
from .shapes import shape_from_spec  # noqa: E402
from .world import World  # noqa: E402

__all__ = ["Contacts", "Settings", "SpecError", "World", "__version__", "collide",
           "load_scene", "preset", "read_scene", "sdf", "shape_from_spec"]
