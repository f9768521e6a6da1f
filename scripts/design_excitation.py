#!/usr/bin/env python3
"""Thin wrapper of ``jointrig design`` (the code is in jointrig/commands/design_excitation.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["design", *sys.argv[1:]]))
