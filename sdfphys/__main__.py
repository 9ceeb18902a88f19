"""``python -m sdfphys``: the same command line as the ``sdfphys`` script."""

import sys

from sdfphys.cli import main

sys.exit(main())
