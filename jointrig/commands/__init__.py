"""The subcommands of the ``jointrig`` command; ``scripts/*.py`` are thin wrappers around them.

Each module has ``main(argv) -> int`` (raises ``ValueError`` for bad input); :func:`jointrig.cli.main`
runs it through :func:`jointrig.commands.options.run_cli` (the exit status of :data:`EXIT_STATUS`,
no traceback).
"""

from __future__ import annotations


#: The exit status of every subcommand and of ``jointrig`` itself (:func:`jointrig.commands.options.run_cli`
#: returns them): a verdict is what a command reports, not how it ended.
EXIT_STATUS = ("Exit status: 0 when the job ran, whatever its verdict (the verdict is in the output); 1 when a "
               "simulation or an identification failed; 2 for bad input (the message names the file, run, column "
               "or option); 130 when interrupted (no output is left half written).")

#: What an example in a help text runs on: the folders of the source tree jointrig ships.
EXAMPLE_WHERE = "Example (runs as printed in the folder jointrig was cloned into, on the files it ships):"


def epilog(example: str, where: str = EXAMPLE_WHERE) -> str:
    """The end of every help text: the exit status, then an example command that runs as printed
    (``where`` says where it runs, if not on the shipped files)."""
    import textwrap

    return f"{textwrap.fill(EXIT_STATUS, 92)}\n\n{where}\n  {example}"


def command_parser(doc: str, example: str, prog: str | None = None, where: str = EXAMPLE_WHERE):
    """The argument parser every subcommand starts from: its module docstring as the help text
    (examples written as ``jointrig ...``), ``-V/--version``, and the help's end
    (:func:`epilog`: the exit status and ``example``, a command that runs as printed on a shipped
    file). Each subcommand adds ``-q/--quiet`` with :func:`add_quiet`, so the two mean the same
    everywhere."""
    import argparse

    from jointrig import __version__

    p = argparse.ArgumentParser(prog=prog, description=doc, epilog=epilog(example, where),
                                formatter_class=argparse.RawDescriptionHelpFormatter)
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
