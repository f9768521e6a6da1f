#!/usr/bin/env python3
"""Thin wrapper of ``jointrig cases`` (the code is in jointrig/commands/diagnose_cases.py; ``--help`` for options)."""

import sys

from jointrig.commands.diagnose_cases import main, run  # noqa: F401  (main: for tests and callers)

if __name__ == "__main__":
    sys.exit(run())
