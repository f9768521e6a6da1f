#!/usr/bin/env python3
"""Thin wrapper of ``jointrig make-data`` (the code is in jointrig/commands/make_data.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["make-data", *sys.argv[1:]]))
