"""What the simulation gets wrong: diagnose measured joint runs against the nominal model.

    jointrig diagnose DATA.csv [--json OUT] [--rrd OUT] [--report OUT.html]

DATA: a file (CSV, Parquet, MATLAB .mat, HDF5, NI TDMS, UFF 58) or a folder of them, one row
per sample, columns ``run, time, torque, phi1, phi2`` in s, N m, rad (``phi`` may replace
``phi1, phi2``; optional ``omega`` in rad/s; other names with --columns, other units with
--units or in the header as ``phi1 [deg]``). A drive train's file has ``phi1..phiN`` and a
``torque<i>`` per driven body (N = 1 to 8); bodies on slides ``x1..xN`` (``x``) and ``force<i>``
(``force``) in m and N. Each run is one steady-state record of several whole periods at one
drive setting, sampled at any rate (see measured/runs.py).

The tool fits the nominal model (every body's inertia and every joint's law, c phi' + k phi +
gamma phi^3, or your --model; two flywheels are a train of two bodies, the relative angle alone
one body tied to the frame by the joint's law), ranks the physical causes of what it
misses by evidence (a train: at every joint and body), extends the model, and measures the gain by
running both models in the MuJoCo rig under the measured drive of runs held out of the fit
(default: runs of another kind than the fit where the data allow: multisines against stepped
sines, else an inner drive level, else an inner frequency, else every third run;
studies.holdout.holdout_of_another_kind).
"""

from __future__ import annotations

import argparse

import logging
import sys
import time
from pathlib import Path

from jointrig.commands import add_quiet, command_parser
from jointrig.identify.defaults import DEFAULT_MAX_CAUSES
from jointrig.commands.options import BadArgument, check_output, check_range, progress_level

# The numerical stack (MuJoCo; rerun for --rrd; matplotlib for a joint card's figure) is
# imported in main, after the arguments are parsed: ``--help`` and bad options answer at once.

log = logging.getLogger("diagnose")



def add_data_options(p: argparse.ArgumentParser) -> None:
    """The options of reading and diagnosing measured runs, shared by ``diagnose`` and ``card``."""
    p.add_argument("data", type=Path, help="measured runs: a file or a folder of files")
    p.add_argument("--columns", metavar="NAME=COLUMN,...",
                   help="the file's names for the columns, e.g. torque=M_drive,phi1=enc1,phi2=enc2,time=t")
    p.add_argument("--units", metavar="NAME=UNIT,...",
                   help="units of the file's columns when not SI, e.g. time=ms,phi1=deg,phi2=deg,torque=Nmm")
    p.add_argument("--model", type=Path, metavar="MY.xml",
                   help="your MJCF model of the two flywheels or of the drive train (the jointrig_* fields for the "
                        "laws; models/two_flywheels.xml and models/pump_train.xml show both): the diagnosis starts from "
                        "its laws and shows each parameter as written beside what the data say (default: the paper's "
                        "structure c phi' + k phi + gamma phi^3 at every joint, no values as written)")
    p.add_argument("--torque-on", choices=("flywheel1", "flywheel2", "shaft"), default="flywheel1",
                   help="where the file's torque acts: the drive on flywheel 1 (default) or on flywheel 2 (your "
                        "numbering is kept); a torque measured in the shaft is refused with what to record instead")
    p.add_argument("--zero-per-run", action="store_true",
                   help="take each run's mean angles as their zero (encoders zeroed at the start of each recording; "
                        "right for a symmetric joint). Without it such a file is refused")
    p.add_argument("--zeroed", action="store_true",
                   help="the encoders were zeroed together (every twist reads 0 at rest without torque): their zeros "
                        "are kept, and the report says where the data disagree. Without it every angle channel is "
                        "taken about its mean over the fitted runs and each twist's zero is read from the data")
    p.add_argument("--holdout", nargs="+", metavar="RUN",
                   help="run labels held out of the fit for validation (default: runs of another kind than the "
                        "fit: another excitation, else an inner level, else an inner frequency, else every third; "
                        "with one or two runs, the later half of each run's periods)")
    p.add_argument("--validate", type=Path, metavar="OTHER",
                   help="hold out every run of another file or folder (the same bench, same columns and units; any "
                        "excitation the rig can replay: other levels, a multisine) and fit on every run of DATA, as "
                        "benchmarks give a separate validation record. Not with --holdout")
    p.add_argument("--band", type=int, default=20, help="harmonics 0..BAND fitted and compared (default: %(default)s)")
    p.add_argument("--torque-share", type=float, default=0.5,
                   help="the undriven flywheel's inertia over J1 + J2 (J2/(J1+J2) with the drive on flywheel 1), "
                        "needed only for data with the relative angle 'phi', whose twist is fitted as one body "
                        "driven by this share of the torque; from your model's inertias with --model "
                        "(default: %(default)s)")
    p.add_argument("--alpha", type=float, default=1e-3,
                   help="false-alarm probability per round over all causes (default: %(default)s)")
    p.add_argument("--fidelity", type=float, default=None,
                   help="fix the model-fidelity floor relative to each run's largest torque (misfits below it are "
                        "not evidence), e.g. 1e-3; default: measured on each model's noise-free replay in the rig")
    p.add_argument("--max-causes", type=int, default=DEFAULT_MAX_CAUSES,
                   help="the most causes adopted; the evidence decides below it; 0: none, the nominal model's misfit "
                        "described (default: %(default)s)")
    add_quiet(p)


def parse_args(argv=None) -> argparse.Namespace:
    p = command_parser(__doc__, 'jointrig diagnose examples/bench_dry_friction.csv --report runs/bench.html')
    add_data_options(p)
    p.add_argument("--json", type=Path, help="write the diagnosis as JSON")
    p.add_argument("--rrd", type=Path, help="write a rerun recording")
    p.add_argument("--report", type=Path, help="write a self-contained HTML report (tables, SVG figures)")
    p.add_argument("--card", type=Path, metavar="OUT.json",
                   help="also write the joint card (amplitude-dependent stiffness, damping, dissipation) as JSON; a "
                        "train's holds one card per joint ('cards')")
    p.add_argument("--card-png", type=Path, metavar="OUT.png",
                   help="also write the joint card's figure (a train: OUT-joint<j>.png per joint)")
    p.add_argument("--card-only", action="store_true", help="print the joint card, not the diagnosis report")
    p.add_argument("--mjcf", type=Path, metavar="OUT.xml",
                   help="write the identified model (the adopted one: extended if explained, else nominal) as a "
                        "rig model file (jointrig_* fields, inertias) to simulate at once")
    return p.parse_args(argv)


def main(argv=None) -> int:
    return _main(parse_args(argv))


def _main(args: argparse.Namespace) -> int:
    from jointrig.rig.runtime import quiet_mujoco

    quiet_mujoco()

    import numpy as np

    from jointrig.diagnosis import DiagnosisInputError, diagnose
    from jointrig.files import OutputError, write_atomic, write_json_atomic
    from jointrig.measured.runs import RunsFileError
    from jointrig.rig.simulate import SimulationError
    from jointrig.vocab.records import RecordError

    logging.basicConfig(level=progress_level(args.quiet), format="%(message)s",
                        stream=sys.stderr)
    t0 = time.perf_counter()

    def card_figures(runs) -> None:
        # a card figure per joint beside --card-png (write_train_cards), checked before the long work
        N = runs.records[0].n_flywheels
        if args.card_png and N > 2:
            for j in range(1, N):
                check_output(args.card_png.with_name(f"{args.card_png.stem}-joint{j}{args.card_png.suffix}"),
                             "--card-png")

    try:
        check_range(args.band, "--band", lo=1, hi=100, integer=True)
        check_range(args.torque_share, "--torque-share", lo=0, hi=1, lo_open=True, hi_open=True)
        check_range(args.alpha, "--alpha", lo=0, hi=1, lo_open=True, hi_open=True)
        if args.fidelity is not None:
            check_range(args.fidelity, "--fidelity", lo=0, hi=0.5)
        check_range(args.max_causes, "--max-causes", lo=0, hi=20, integer=True)
        for option, path in (("--json", args.json), ("--rrd", args.rrd), ("--report", args.report),
                             ("--card", args.card), ("--card-png", args.card_png), ("--mjcf", args.mjcf)):
            check_output(path, option)
        d = diagnose(args.data, model=args.model, holdout=args.holdout, validate=args.validate, columns=args.columns,
                     units=args.units, zero_per_run=args.zero_per_run, zeroed=args.zeroed, torque_on=args.torque_on,
                     torque_share=args.torque_share, band=args.band, alpha=args.alpha, fidelity=args.fidelity,
                     max_causes=args.max_causes, progress=lambda msg: log.info("%s", msg), before=card_figures)
    except (RunsFileError, RecordError, BadArgument, OutputError, DiagnosisInputError) as err:
        return _said(err, 2)
    except (SimulationError, ValueError, np.linalg.LinAlgError) as err:
        return _said(err, 1)
    report, loaded = d.report, d.runs
    text = d.text()
    if not args.card_only:
        print(text)
    cards = ()
    if args.card or args.card_png or args.card_only:
        cards = write_train_cards(args, loaded, report)
    if args.report:
        from jointrig.present.train_report import write_train_html

        write_train_html(args.report, report, text, title=f"jointrig diagnosis of {args.data.name}",
                         source=str(args.data), notes=loaded.notes, input_sha256=loaded.sha256, cards=cards)
        log.info("wrote %s", args.report)
    if args.json:
        write_json_atomic(args.json, d.json())
        log.info("wrote %s", args.json)
    if args.rrd:
        from jointrig.present.recording import log_chain_diagnosis, open_recording

        with open_recording(args.rrd) as rec:
            log_chain_diagnosis(rec, report.diagnosis, report.validation, report.diagnosis.nominal.spec.n_flywheels,
                                report.misfit, text=text, kind=report.kind)
        log.info("wrote %s", args.rrd)
    if args.mjcf:
        from jointrig import __version__
        from jointrig.rig.chain import load_chain

        what = "extended" if report.adopted else "nominal"
        header = (f"jointrig {__version__}: the {what} train identified from {args.data} (SHA-256 {loaded.sha256}).\n"
                  f"Verdict: {report.verdict.verdict}: {d.reason}")

        def write(tmp):
            tmp.write_text(d.model_xml(header), encoding="utf-8")
            load_chain(tmp)  # it must compile and read back before it replaces anything

        write_atomic(args.mjcf, write)
        log.info("wrote %s", args.mjcf)
    log.info("done in %.1f s", time.perf_counter() - t0)
    return 0


def _said(err: Exception, status: int) -> int:
    """The message of a diagnosis that stops: bad input (exit 2) or a failed identification (1)."""
    print(f"diagnose: {'error' if status == 2 else 'the identification failed'}: {err}", file=sys.stderr)
    return status


def write_train_cards(args, loaded, report) -> tuple:
    """The card of every place of a train (every joint; a single body: its guide), printed, as
    one JSON (``cards``: one two-flywheel card each, with its ``place``) and one PNG per place
    (``OUT-joint<j>.png``; a single body's: ``OUT.png``). Returns ``(card, its PNG)`` per place
    (the PNG drawn once, for the report too)."""
    from jointrig.files import write_atomic, write_json_atomic
    from jointrig.present.card import card_json, card_png, format_card, model_name
    from jointrig.studies.joint_card import cards_of_train

    log.info("computing the joint cards")
    cards = cards_of_train(report, loaded.records)
    for c in cards:
        print(format_card(c))
    if args.card:
        write_json_atomic(args.card, {"source": str(args.data), "input_sha256": loaded.sha256,
                                      "cards": [card_json(c) for c in cards]})
        log.info("wrote %s", args.card)
    pngs = [card_png(c, title=f"joint card of {args.data.name}, {c.place}: {model_name(c)}")
            if args.card_png or args.report else b"" for c in cards]
    if args.card_png:
        for c, png in zip(cards, pngs):
            path = args.card_png if len(cards) == 1 else args.card_png.with_name(
                f"{args.card_png.stem}-{c.place.replace(' ', '')}{args.card_png.suffix}")
            write_atomic(path, lambda tmp, png=png: tmp.write_bytes(png))
            log.info("wrote %s", path)
    return tuple(zip(cards, pngs))
