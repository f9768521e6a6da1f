"""The subcommands of the ``jointrig`` command; ``scripts/*.py`` are thin wrappers around them.

Each module has ``main(argv) -> int`` (raises ``ValueError`` for bad input); :func:`jointrig.cli.main`
runs it through :func:`jointrig.commands.options.run_cli` (exit 2 for bad input, 1 for a failed
simulation or identification, no traceback).
"""

from __future__ import annotations


def command_parser(doc: str, prog: str | None = None):
    """The argument parser every subcommand starts from: its module docstring as the help text
    (examples written as ``jointrig ...``) and ``-V/--version``. Each subcommand adds
    ``-q/--quiet`` with :func:`add_quiet`, so the two mean the same everywhere."""
    import argparse

    from jointrig import __version__

    p = argparse.ArgumentParser(prog=prog, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-V", "--version", action="version", version=f"jointrig {__version__}")
    return p


def add_quiet(p) -> None:
    """``-q/--quiet``: no progress lines on stderr (results and warnings only)."""
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines (results and warnings only)")


def shipped(path) -> str:
    """How a help text names a model file shipped with jointrig: by its place in the source tree
    (``models/NAME``), not an absolute path of one machine."""
    from pathlib import Path

    return f"models/{Path(path).name} (shipped with jointrig)"
