#!/usr/bin/env python3
"""Thin wrapper of ``jointrig design`` (the code is in jointrig/commands/design_excitation.py; ``--help`` for options)."""

import sys

from jointrig.commands.design_excitation import main, run  # noqa: F401  (main: for tests and callers)

if __name__ == "__main__":
    sys.exit(run())
