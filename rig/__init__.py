"""The MuJoCo virtual test rig: two flywheels (or a chain of them) joined by nonlinear joints,
driven periodically, simulated to steady state.

Submodules: :mod:`model` (MJCF rigs), :mod:`simulate` (steady state), :mod:`callback` (MuJoCo's
global passive callback, scoped), :mod:`native_callback` (the callback in C), :mod:`chain`
(drive trains), :mod:`oscillator` (the one-coordinate rig of the Silverbox), :mod:`measurement`
(the sensors' noise) and :mod:`runtime` (a command's process settings). What is run with the
rig lives in ``jointrig.studies``; what people read, in ``jointrig.present``.
"""

import importlib

#: Public names of the package and the submodule each comes from, imported on first use
#: (PEP 562): ``import jointrig.rig.runtime`` or a command's ``--help`` does not load MuJoCo.
_LAZY = {
    **{n: "model" for n in ("DEFAULT_MODEL", "RigModel", "RigModelError", "law_from_model", "load_rig",
                            "plant_from_model")},
    **{n: "simulate" for n in ("SettleInfo", "SimulationConfig", "SimulationError", "SteadyStateNotReached",
                               "commit_state", "make_callback", "passive_callback", "simulate_steady_state")},
}


def __getattr__(name):
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "DEFAULT_MODEL", "RigModel", "RigModelError", "SettleInfo", "SimulationConfig", "SimulationError",
    "SteadyStateNotReached", "law_from_model", "load_rig", "make_callback", "passive_callback",
    "simulate_steady_state", "plant_from_model", "commit_state",
]
