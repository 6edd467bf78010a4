"""``python -m crumple.cli``."""

import sys

from . import main

sys.exit(main())
