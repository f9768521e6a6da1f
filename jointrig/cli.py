"""The ``jointrig`` command (also ``python -m jointrig``): one subcommand per job.

    jointrig diagnose DATA    what the simulation gets wrong about measured runs
    jointrig card DATA        the joint card (backbone, damping, dissipation) of measured runs
    jointrig sweep ...        frequency x amplitude sweep of a rig model and its identification
    jointrig make-data OUT    simulate measured runs of a model (CSV/Parquet)
    jointrig design           D-optimal excitation on a test-time budget
    jointrig card-check       the identified card against a virtual phase-resonance test
    jointrig unknown-law      a joint law of unknown form on hat functions
    jointrig diagnose-chain   which joint of a drive train is worn, and how (a demo)
    jointrig cases            every hidden-effect case of the diagnosis
    jointrig paper            the paper's example, eq. (12)
    jointrig silverbox        the Silverbox benchmark on the real files

``jointrig SUBCOMMAND --help`` lists the subcommand's options with units and defaults;
``jointrig -V`` prints the version, and ``-q`` before a subcommand is its own ``-q``.
"""

from __future__ import annotations

import importlib
import os
import sys

from jointrig import __version__

#: subcommand -> (module in jointrig.commands, one-line summary): the commands for the user's
#: measured runs first (:data:`ON_YOUR_DATA`), then the rig's jobs and demos
SUBCOMMANDS = {
    "diagnose": ("diagnose", "what the simulation gets wrong about measured runs (a file or a folder)"),
    "card": ("card", "the joint card: amplitude-dependent stiffness, damping and dissipation of measured runs"),
    "sweep": ("run_sweep", "frequency x amplitude sweep of a rig model and its identification"),
    "make-data": ("make_data", "simulate measured runs of a model and write them (CSV/Parquet)"),
    "design": ("design_excitation", "D-optimal excitation on a test-time budget"),
    "card-check": ("card_check", "the identified joint card against a virtual phase-resonance test in the rig"),
    "unknown-law": ("unknown_law", "a joint law of unknown form on hat functions, with its band"),
    "diagnose-chain": ("diagnose_chain", "which joint of a drive train is worn, and how (a demo on a chain model)"),
    "cases": ("diagnose_cases", "how the diagnosis does on every hidden-effect case"),
    "paper": ("paper_example", "the paper's example, eq. (12)"),
    "silverbox": ("silverbox", "the Silverbox benchmark on the real files"),
}
#: the subcommands that take the user's measured runs
ON_YOUR_DATA = ("diagnose", "card")


def _usage() -> str:
    from jointrig.commands import epilog

    width = max(map(len, SUBCOMMANDS))

    def listed(names):
        return [f"  {name:{width}s}  {SUBCOMMANDS[name][1]}" for name in names]

    lines = [f"usage: jointrig [-V | --version] [-q | --quiet] SUBCOMMAND [options]   (jointrig {__version__})", "",
             "on your measured runs:"]
    lines += listed(ON_YOUR_DATA)
    lines += ["", "the virtual rig, its demos and benchmarks:"]
    lines += listed([n for n in SUBCOMMANDS if n not in ON_YOUR_DATA])
    lines += ["", "jointrig SUBCOMMAND --help lists its options with units and defaults.", "",
              epilog("jointrig diagnose examples/bench_dry_friction.csv")]
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
