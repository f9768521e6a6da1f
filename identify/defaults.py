"""Defaults of the diagnosis that the command line shows in its help (a light module: importing
it loads neither scipy nor the rig, so ``jointrig diagnose --help`` starts at once)."""

#: Model-fidelity floor, relative to each run's largest balanced torque (see
#: :func:`identify.chain_diagnose.diagnose_chain`).
DEFAULT_FIDELITY = 1e-3
