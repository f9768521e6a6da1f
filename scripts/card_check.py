#!/usr/bin/env python3
"""Thin wrapper of ``jointrig card-check`` (the code is in jointrig/commands/card_check.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["card-check", *sys.argv[1:]]))
