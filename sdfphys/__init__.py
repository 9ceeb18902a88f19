"""sdfphys: a 2D rigid-body physics sandbox whose collision core is signed distance fields.

``import sdfphys`` never imports pygame: drawing, video and the interactive
window live in ``sdfphys.render``, ``sdfphys.video`` and ``sdfphys.play``.
"""

from . import sdf
from .errors import SpecError

__version__ = "0.1.0"

__all__ = ["sdf", "SpecError", "__version__"]
