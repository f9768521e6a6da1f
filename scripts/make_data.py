#!/usr/bin/env python3
"""Thin wrapper of ``jointrig make-data`` (the code is in jointrig/commands/make_data.py; ``--help`` for options)."""

import sys

from jointrig.commands.make_data import main, run  # noqa: F401  (main: for tests and callers)

if __name__ == "__main__":
    sys.exit(run())
