"""jointrig: a MuJoCo virtual test rig and harmonic-balance identifier for nonlinear joints.

The distribution installs one namespace; the folders of the repository map onto it:

    jointrig.identify  <- identify/   pure mathematics (records, law, balance, solve, diagnosis)
    jointrig.rig       <- rig/        the MuJoCo rig, studies, presentation
    jointrig.measured  <- measured/   readers of measured data
    jointrig.models    <- models/     MJCF model files (package data)
    jointrig.commands  <- jointrig/commands/  the ``jointrig`` command's subcommands

From Python, ``jointrig.diagnose(path)`` runs the diagnosis of measured runs and returns a
:class:`jointrig.diagnosis.Diagnosis` (imported on first use: ``import jointrig`` stays light).
"""

from jointrig.version import __version__

__all__ = ["__version__", "diagnose", "Diagnosis"]


def __getattr__(name):
    if name in ("diagnose", "Diagnosis", "DiagnosisInputError"):
        from jointrig import diagnosis

        return getattr(diagnosis, name)
    raise AttributeError(f"module 'jointrig' has no attribute {name!r}")
