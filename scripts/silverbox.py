#!/usr/bin/env python3
"""Thin wrapper of ``jointrig silverbox`` (the code is in jointrig/commands/silverbox.py; ``--help`` for options)."""

import sys

from jointrig.commands.silverbox import main, run  # noqa: F401  (main: for tests and callers)

if __name__ == "__main__":
    sys.exit(run())
