"""The joint card of measured runs: amplitude-dependent stiffness, damping and dissipation.

    jointrig card DATA [--json OUT.json] [--png OUT.png] [--holdout RUN ...] [--columns ...] [--units ...]

The runs are diagnosed first (``jointrig diagnose``: the nominal model, the causes, the adopted
extension, validated in the rig); the card is then computed twice (identify/card.py,
studies/joint_card.py): from the runs alone (first harmonics and loop areas, the inertias from the
fit) and from the identified model (describing function), at each run's amplitude and drive
frequency and along the model's backbone. Every joint gets one (two flywheels: joint 1; a single
body: at its guide). It prints the cards; ``--json`` holds them as ``cards``, each with its
``place`` and a list ``amplitudes`` (``amplitude_rad``, ``natural_frequency_rad_s``,
``damping_ratio``, ``dissipation_J_per_cycle``, ``secant_stiffness_Nm_per_rad``, each with
``_std``, and ``source``: runs, model_at_runs, model) and the dissipation slopes with their
standard errors; ``--png OUT.png`` writes the figure (a train of more joints: ``OUT-joint<j>.png``
per joint).
"""

from __future__ import annotations

from pathlib import Path

from jointrig.commands import command_parser, diagnose


def main(argv=None) -> int:
    p = command_parser(__doc__, 'jointrig card examples/bench_dry_friction.csv --png runs/card.png')
    diagnose.add_data_options(p)
    p.add_argument("--json", type=Path, help="write the card as JSON")
    p.add_argument("--png", type=Path, help="write the card's figure (PNG)")
    args = p.parse_args(argv)
    from jointrig.commands.options import check_output

    # Checked here to name this command's options (diagnose would name them --card, --card-png).
    check_output(args.json, "--json")
    check_output(args.png, "--png")
    forwarded = [str(args.data), "--card-only", "--band", str(args.band), "--torque-share", str(args.torque_share),
                 "--alpha", str(args.alpha), "--max-causes", str(args.max_causes)]
    if args.fidelity is not None:
        forwarded += ["--fidelity", str(args.fidelity)]
    for option, value in (("--columns", args.columns), ("--units", args.units), ("--card", args.json),
                          ("--card-png", args.png)):
        if value is not None:
            forwarded += [option, str(value)]
    if args.holdout:
        forwarded += ["--holdout", *args.holdout]
    if args.quiet:
        forwarded.append("-q")
    if args.zero_per_run:
        forwarded.append("--zero-per-run")
    if args.zeroed:
        forwarded.append("--zeroed")
    if args.model is not None:
        forwarded += ["--model", str(args.model)]
    forwarded += ["--torque-on", args.torque_on]
    return diagnose.main(forwarded)
