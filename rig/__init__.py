"""The MuJoCo virtual test rig: two flywheels joined by a nonlinear joint, driven harmonically.

Submodules beyond the core: :mod:`measurement` (noise model), :mod:`validate` (diagnosis with
validation in the rig), :mod:`diagnosis_report`, :mod:`hidden_effects` (ground-truth cases),
:mod:`native_callback` (the callback in C).
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
