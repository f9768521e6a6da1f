"""jointrig: a MuJoCo virtual test rig and harmonic-balance identifier for nonlinear joints.

The distribution installs one namespace; the folders of the repository map onto it:

    jointrig.identify  <- identify/   pure mathematics (records, law, balance, solve, diagnosis)
    jointrig.rig       <- rig/        the MuJoCo rig, studies, presentation
    jointrig.measured  <- measured/   readers of measured data
    jointrig.models    <- models/     MJCF model files (package data)
    jointrig.commands  <- jointrig/commands/  the ``jointrig`` command's subcommands
"""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("jointrig")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

__all__ = ["__version__"]
