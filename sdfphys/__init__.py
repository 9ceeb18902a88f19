"""sdfphys: a 2D rigid-body physics sandbox whose collision core is signed distance fields.

``import sdfphys`` never imports pygame: drawing, video and the interactive
window live in ``sdfphys.render``, ``sdfphys.video`` and ``sdfphys.play``.
"""

from . import sdf
from .collide import Contacts, collide
from .errors import SpecError
from .scene import load_scene, read_scene
from .settings import Settings, preset
from .shapes import shape_from_spec
from .world import World

__version__ = "0.1.0"

__all__ = ["Contacts", "Settings", "SpecError", "World", "__version__", "collide",
           "load_scene", "preset", "read_scene", "sdf", "shape_from_spec"]
