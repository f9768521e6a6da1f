#!/usr/bin/env python3
"""Thin wrapper of ``jointrig unknown-law`` (the code is in jointrig/commands/unknown_law.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["unknown-law", *sys.argv[1:]]))
