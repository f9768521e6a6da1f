"""Defaults of the diagnosis that the command line shows in its help (a light module: importing
it loads neither scipy nor the rig, so ``jointrig diagnose --help`` starts at once)."""

#: Model-fidelity floor, relative to each run's largest balanced torque (see
#: :func:`identify.chain_diagnose.diagnose_chain`).
DEFAULT_FIDELITY = 1e-3

#: The most causes a diagnosis adopts (``--max-causes``): the evidence decides below it (each
#: must be significant beside the ones before it and pass parsimony); the limit only bounds the
#: work on a train of eight bodies, where every round scores every cause at every place.
DEFAULT_MAX_CAUSES = 4
