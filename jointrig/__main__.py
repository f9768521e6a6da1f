"""``python -m jointrig``: the same as the ``jointrig`` command."""

import sys

from jointrig.cli import main

sys.exit(main())
