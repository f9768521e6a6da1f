#!/usr/bin/env python3
"""Thin wrapper of ``jointrig unknown-law`` (the code is in jointrig/commands/unknown_law.py; ``--help`` for options)."""

import sys

from jointrig.commands.unknown_law import main, run  # noqa: F401  (main: for tests and callers)

if __name__ == "__main__":
    sys.exit(run())
