"""The ``jointrig`` command (also ``python -m jointrig``): one subcommand per job.

    jointrig sweep ...        frequency x amplitude sweep of a rig model and its identification
    jointrig diagnose DATA    what the simulation gets wrong about measured runs
    jointrig card DATA        the joint card (backbone, damping, dissipation) of measured runs
    jointrig card-check       the identified card against a virtual phase-resonance test
    jointrig make-data OUT    simulate measured runs of a model (CSV/Parquet)
    jointrig design           D-optimal excitation on a test-time budget
    jointrig unknown-law      a joint law of unknown form on hat functions
    jointrig silverbox        the Silverbox benchmark on the real files
    jointrig paper            the paper's example, eq. (12)
    jointrig cases            every hidden-effect case of the diagnosis
    jointrig diagnose-chain   which joint of a drive train is worn, and how

``jointrig SUBCOMMAND --help`` lists the subcommand's options with units and defaults;
``jointrig -V`` prints the version, and ``-q`` before a subcommand is its own ``-q``.
"""

from __future__ import annotations

import importlib
import os
import sys

from jointrig import __version__

#: subcommand -> (module in jointrig.commands, one-line summary)
SUBCOMMANDS = {
    "sweep": ("run_sweep", "frequency x amplitude sweep of a rig model and its identification"),
    "diagnose": ("diagnose", "what the simulation gets wrong about measured runs (a file or a folder)"),
    "card": ("card", "the joint card: amplitude-dependent stiffness, damping and dissipation of measured runs"),
    "card-check": ("card_check", "the identified joint card against a virtual phase-resonance test in the rig"),
    "make-data": ("make_data", "simulate measured runs of a model and write them (CSV/Parquet)"),
    "design": ("design_excitation", "D-optimal excitation on a test-time budget"),
    "unknown-law": ("unknown_law", "a joint law of unknown form on hat functions, with its band"),
    "silverbox": ("silverbox", "the Silverbox benchmark on the real files"),
    "paper": ("paper_example", "the paper's example, eq. (12)"),
    "cases": ("diagnose_cases", "how the diagnosis does on every hidden-effect case"),
    "diagnose-chain": ("diagnose_chain", "which joint of a drive train is worn, and how (a chain model)"),
}


def _usage() -> str:
    width = max(map(len, SUBCOMMANDS))
    lines = [f"usage: jointrig [-V | --version] [-q | --quiet] SUBCOMMAND [options]   (jointrig {__version__})", "",
             "subcommands:"]
    lines += [f"  {name:{width}s}  {summary}" for name, (_, summary) in SUBCOMMANDS.items()]
    lines += ["", "jointrig SUBCOMMAND --help lists its options with units and defaults."]
    return "\n".join(lines)


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(_usage())
        return 0 if argv else 2
    if argv[0] in ("-V", "--version"):
        print(f"jointrig {__version__}")
        return 0
    quiet = []  # -q before the subcommand is the subcommand's -q: no progress, as at every level
    while argv and argv[0] in ("-q", "--quiet"):
        quiet, argv = ["-q"], argv[1:]
    if not argv:
        print(_usage(), file=sys.stderr)
        return 2
    name, rest = argv[0], argv[1:] + quiet
    if name not in SUBCOMMANDS:
        print(f"jointrig: error: unknown subcommand {name!r}; expected one of {', '.join(SUBCOMMANDS)}",
              file=sys.stderr)
        return 2
    from jointrig.rig.runtime import limit_threads
    from jointrig.commands.options import run_cli

    # No command renders with MuJoCo (the recordings are rerun's): without this, importing
    # mujoco loads its OpenGL backend (GLFW), 0.05 s of every command's start. A value the
    # user set is kept.
    os.environ.setdefault("MUJOCO_GL", "disable")
    # One BLAS/OpenMP thread per process for every command, set before numpy loads (a pool
    # the user sized is kept): the project's parallelism is its own (forked workers, threads).
    limit_threads()
    module = importlib.import_module(f"jointrig.commands.{SUBCOMMANDS[name][0]}")
    # argparse names the program after argv[0]: "usage: jointrig diagnose ...", not "jointrig".
    argv0, sys.argv[0] = sys.argv[0], f"jointrig {name}"
    try:
        return run_cli(module.main, f"jointrig {name}", rest)
    finally:
        sys.argv[0] = argv0


if __name__ == "__main__":
    sys.exit(main())
