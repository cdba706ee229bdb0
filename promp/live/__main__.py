"""``python -m promp.live``: see :mod:`promp.live.cli`."""

import sys

from promp.live.cli import main

sys.exit(main())
