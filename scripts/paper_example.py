#!/usr/bin/env python3
"""Thin wrapper of ``jointrig paper`` (the code is in jointrig/commands/paper_example.py; ``--help`` for options)."""

import sys

from jointrig.commands.paper_example import main, run  # noqa: F401  (main: for tests and callers)

if __name__ == "__main__":
    sys.exit(run())
