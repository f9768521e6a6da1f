#!/usr/bin/env python3
"""Thin wrapper of ``jointrig cases`` (the code is in jointrig/commands/diagnose_cases.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["cases", *sys.argv[1:]]))
