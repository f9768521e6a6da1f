#!/usr/bin/env python3
"""Thin wrapper of ``jointrig sweep`` (the code is in jointrig/commands/run_sweep.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["sweep", *sys.argv[1:]]))
