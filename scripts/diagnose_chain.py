#!/usr/bin/env python3
"""Thin wrapper of ``jointrig diagnose-chain`` (the code is in jointrig/commands/diagnose_chain.py; ``--help`` for options)."""

import sys

from jointrig.cli import main

if __name__ == "__main__":
    sys.exit(main(["diagnose-chain", *sys.argv[1:]]))
