#!/usr/bin/env python3
"""Thin wrapper of ``jointrig diagnose`` (the code is in jointrig/commands/diagnose.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["diagnose", *sys.argv[1:]]))
