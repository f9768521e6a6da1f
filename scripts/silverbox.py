#!/usr/bin/env python3
"""Thin wrapper of ``jointrig silverbox`` (the code is in jointrig/commands/silverbox.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["silverbox", *sys.argv[1:]]))
