"""``python -m shieldnav``: the same command line as the ``shieldnav`` script."""

import sys

from shieldnav.cli import main

sys.exit(main())
