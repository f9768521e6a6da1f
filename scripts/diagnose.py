#!/usr/bin/env python3
"""Thin wrapper of ``jointrig diagnose`` (the code is in jointrig/commands/diagnose.py; ``--help`` for options)."""

import sys

from jointrig.commands.diagnose import main, run  # noqa: F401  (main: for tests and callers)

if __name__ == "__main__":
    sys.exit(run())
