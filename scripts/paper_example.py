#!/usr/bin/env python3
"""Thin wrapper of ``jointrig paper`` (the code is in jointrig/commands/paper_example.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["paper", *sys.argv[1:]]))
