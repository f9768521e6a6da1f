"""The subcommands of the ``jointrig`` command; ``scripts/*.py`` are thin wrappers around them.

Each module has ``main(argv) -> int`` (raises ``ValueError`` for bad input); :func:`jointrig.cli.main`
runs it through :func:`jointrig.rig.runtime.run_cli` (exit 2 for bad input, 1 for a failed
simulation or identification, no traceback).
"""
