#!/usr/bin/env python3
"""Thin wrapper of ``jointrig sweep`` (the code is in jointrig/commands/run_sweep.py; ``--help`` for options)."""

import sys

from jointrig.commands.run_sweep import main, run  # noqa: F401  (main: for tests and callers)

if __name__ == "__main__":
    sys.exit(run())
