#!/usr/bin/env python3
"""Mutation testing of the identifier's core and the measured-runs loader.

    .venv/bin/pip install -e ".[test,mutation]"
    .venv/bin/python scripts/mutation_test.py [--sample 60] [--seed 0] [--workers 2]
                                              [--out runs/mutation.json] [--module NAME ...]

Mutants are made by cosmic-ray's operators (a well-kept mutation library; its own runner
would start a fresh interpreter and the whole test file set per mutant, hours for the ~2,500
mutants here): arithmetic swaps (+ -, * /, ** *), comparison swaps (< <=, == !=, is / is
not), numbers +-1, negated conditions, True/False, and/or, break/continue, loops skipped,
unary minus removed; not on lines that change no observable result (decorators, the
positional-only ``/`` and the keyword-only ``*``, error-message text, ``# pragma: no mutate``). A random sample of ``--sample`` mutants per module (seeded)
is run, so the kill rate is an estimate with its binomial standard error; ``--sample 0``
runs all.

Each mutant runs in a forked child of a process that has already imported numpy, scipy,
mujoco and pytest: the child serves the mutated source for that one module through an import
hook (nothing is written to the source tree, so two workers never see each other's mutants)
and runs the module's own tests with ``-x`` (the first failure kills the mutant). A child
that runs past ``--timeout`` seconds is killed and counts as killed (the mutant made the code
hang). Results go to a JSON file, written atomically after every mutant: an interrupted run
resumes where it stopped.
"""

from __future__ import annotations

import argparse
import difflib
import json
import math
import os
import random
import re
import signal
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# One BLAS thread per worker, set before numpy loads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

#: module -> (its file, the tests that pin it, in the order they run: fast ones first)
MODULES = {
    "jointrig.identify.harmonics": ("identify/harmonics.py", ["tests/test_harmonics.py",
                                                             "tests/test_identify_analytic.py", "tests/test_eiv.py"]),
    "jointrig.identify.balance": ("identify/balance.py", ["tests/test_identify_analytic.py", "tests/test_basis.py",
                                                         "tests/test_eiv.py"]),
    "jointrig.identify.solve": ("identify/solve.py", ["tests/test_identify_analytic.py", "tests/test_eiv.py"]),
    # test_hat.py: the penalised path of eiv (solve_penalised, penalty rows) is used by the hat fit
    "jointrig.identify.eiv": ("identify/eiv.py", ["tests/test_eiv.py", "tests/test_identify_analytic.py",
                                                 "tests/test_hat.py"]),
    "jointrig.identify.periods": ("identify/periods.py", ["tests/test_runs_file.py", "tests/test_bad_input.py",
                                                         "tests/test_validate_record.py"]),
    "jointrig.identify.zeros": ("identify/zeros.py", ["tests/test_sensor_zeros.py"]),
    # dry friction's kinks restored in a band-limited rate, and its switches moved per period
    "jointrig.identify.kink": ("identify/kink.py", ["tests/test_kink.py"]),
    "jointrig.measured.runs": ("measured/runs.py", ["tests/test_runs_file.py", "tests/test_train_loader.py",
                                                   "tests/test_bad_input.py"]),
    "jointrig.measured.formats": ("measured/formats.py", ["tests/test_runs_file.py", "tests/test_bad_input.py"]),
    # the diagnosis package's shared pieces: the verdict, the catalogue's evidence, profile
    # search, parsimony and forward selection
    "jointrig.identify.verdict": ("identify/verdict.py", ["tests/test_verdict_judge.py"]),
    # the weighted chi-square and covariance of every diagnosis fit
    "jointrig.identify.estimates": ("identify/estimates.py", ["tests/test_calibration.py",
                                                             "tests/test_chain_diagnose.py"]),
    "jointrig.identify.causes": ("identify/causes.py", ["tests/test_causes.py", "tests/test_verdict_judge.py"]),
    # what an unexplained misfit looks like, on every bench, and the one JSON document
    "jointrig.identify.misfit": ("identify/misfit.py", ["tests/test_misfit.py", "tests/test_train_misfit.py"]),
    "jointrig.present.diagnosis_json": ("present/diagnosis_json.py", ["tests/test_diagnosis_json.py"]),
    # the sentences of the notes, rejections, verdict and failed replays, and of a misfit
    "jointrig.present.notes": ("present/notes.py", ["tests/test_notes.py", "tests/test_verdict_judge.py",
                                                    "tests/test_causes.py", "tests/test_holdout.py"]),
    "jointrig.present.misfit_words": ("present/misfit_words.py", ["tests/test_misfit.py", "tests/test_train_misfit.py"]),
    # the user's model as written beside the data
    "jointrig.present.summary": ("present/summary.py", ["tests/test_formatting.py"]),
    # the replay of held-out runs: what a right model misses there (fast tests first), its start,
    # its constant loads, its span, its noise floor
    "jointrig.studies.chain_validate": ("studies/chain_validate.py", ["tests/test_chain.py", "tests/test_right_model.py",
                                                                       "tests/test_verdict_judge.py",
                                                                       "tests/test_validate_record.py",
                                                                       "tests/test_preload.py",
                                                                       "tests/test_calibration.py"]),
    # the law's terms (their columns, model-file fields, C cases and sliders), in the basis tests
    # and in the rig's trajectories (Python and C callbacks), the identification and the card
    "jointrig.vocab.law": ("jointrig/vocab/law.py", ["tests/test_basis.py", "tests/test_effects_rig.py",
                                                    "tests/test_rig.py", "tests/test_identify_rig.py",
                                                    "tests/test_dry_friction_rig.py", "tests/test_eiv.py",
                                                    "tests/test_native_callback.py", "tests/test_card.py",
                                                    "tests/test_chain.py"]),
    # the joint card, of two flywheels and of every joint of a train
    "jointrig.identify.card": ("identify/card.py", ["tests/test_card.py"]),
    # a train's harmonic balance (stick masks, the drives' lag) and its diagnosis
    "jointrig.identify.chain": ("identify/chain.py", ["tests/test_calibration.py", "tests/test_chain.py"]),
    # (test_preload.py: the final model's profiled parameters refined together under mean loads)
    "jointrig.identify.chain_diagnose": ("identify/chain_diagnose.py", ["tests/test_calibration.py",
                                                                       "tests/test_chain_diagnose.py",
                                                                       "tests/test_train_misfit.py",
                                                                       "tests/test_preload.py"]),
}
#: tests that exercise other parts of the project and only cost time here
DESELECT = "not killed_sweep_resumes and not truncated_store_point and not dask"

#: cosmic-ray operators used: one natural counterpart per operator (as mutmut does), not
#: every operator into every other (most of those are killed by any test that runs the line).
OPERATORS = (
    [f"core/ReplaceBinaryOperator_{a}_{b}" for a, b in (("Add", "Sub"), ("Sub", "Add"), ("Mul", "Div"),
                                                         ("Div", "Mul"), ("Pow", "Mul"), ("FloorDiv", "Div"),
                                                         ("Mod", "FloorDiv"))]
    + [f"core/ReplaceComparisonOperator_{a}_{b}" for a, b in (("Lt", "LtE"), ("LtE", "Lt"), ("Gt", "GtE"),
                                                              ("GtE", "Gt"), ("Eq", "NotEq"), ("NotEq", "Eq"),
                                                              ("Is", "IsNot"), ("IsNot", "Is"))]
    + ["core/NumberReplacer", "core/AddNot", "core/ReplaceTrueWithFalse", "core/ReplaceFalseWithTrue",
       "core/ReplaceAndWithOr", "core/ReplaceOrWithAnd", "core/ReplaceBreakWithContinue", "core/ZeroIterationForLoop",
       "core/ReplaceUnaryOperator_Delete_USub"])


#: Lines whose mutants change no result a caller can observe, not generated (as mutmut skips
#: decorators and pragmas): decorators (``@dataclass(frozen=True)``, cache sizes), the ``/``
#: that marks positional-only parameters, the text of error messages (``raise ...``, message
#: continuation lines) and lines marked ``# pragma: no mutate``.
_SKIP_LINE = re.compile(r"""^\s*(@|raise\b|f?["']|.*#\s*pragma:\s*no mutate)""")
_SIGNATURE_SLASH = re.compile(r"(^|[(,])\s*/\s*(,|\)|$)")
#: the bare ``*`` that makes the parameters after it keyword-only: turned into ``/`` it only lets
#: callers pass them by position as well (every caller names them): no observable change
_SIGNATURE_STAR = re.compile(r"(^|[(,])\s*\*\s*(,|\)|$)")


def _skipped(operator: str, line: str) -> bool:
    if _SKIP_LINE.match(line):
        return True
    code = line.split("#")[0]
    return ("_Div_" in operator and bool(_SIGNATURE_SLASH.search(code))) or (
        "_Mul_Div" in operator and bool(_SIGNATURE_STAR.search(code)))


def enumerate_mutants(module: str) -> list[dict]:
    """Every (operator, occurrence) of the chosen operators in the module's source, with its
    line, as cosmic-ray's ``init`` finds them (occurrences keep cosmic-ray's numbering), less
    those on lines :func:`_skipped` names."""
    import cosmic_ray.plugins
    from cosmic_ray.ast import ast_nodes, get_ast

    path = ROOT / MODULES[module][0]
    source = path.read_text(encoding="utf-8")
    lines = source.splitlines()
    tree = get_ast(source)
    out = []
    for name in OPERATORS:
        op = cosmic_ray.plugins.get_operator(name)()
        positions = [start for node in ast_nodes(tree) for start, _ in op.mutation_positions(node)]
        out += [{"module": module, "operator": name, "occurrence": k, "line": start[0]}
                for k, start in enumerate(positions) if not _skipped(name, lines[start[0] - 1])]
    return out


def mutated_source(m: dict) -> str | None:
    import cosmic_ray.plugins
    from cosmic_ray.mutating import mutate_code

    source = (ROOT / MODULES[m["module"]][0]).read_text(encoding="utf-8")
    return mutate_code(source, cosmic_ray.plugins.get_operator(m["operator"])(), m["occurrence"])


def _key(m: dict) -> str:
    return f"{m['module']}:{m['operator']}:{m['occurrence']}"


class _MutantFinder:
    """Serves the mutated source for one module name; every other import goes on as usual."""

    def __init__(self, name: str, path: Path, source: str):
        self.name, self.path, self.source = name, path, source

    def find_spec(self, fullname, path=None, target=None):
        import importlib.util

        if fullname != self.name:
            return None
        return importlib.util.spec_from_loader(fullname, self, origin=str(self.path))

    def create_module(self, spec):
        return None

    def exec_module(self, module):
        module.__file__ = str(self.path)
        exec(compile(self.source, str(self.path), "exec"), module.__dict__)


def _child(m: dict, source: str, timeout_s: float) -> None:
    """In the forked child: import the project afresh with the mutant in place and run the
    module's tests; exit 0 if they pass (the mutant survived)."""
    import pytest

    signal.signal(signal.SIGALRM, lambda *a: os._exit(3))
    signal.alarm(int(math.ceil(timeout_s)))
    for name in [n for n in sys.modules if n == "jointrig" or n.startswith("jointrig.")]:
        del sys.modules[name]
    sys.dont_write_bytecode = True
    sys.meta_path.insert(0, _MutantFinder(m["module"], ROOT / MODULES[m["module"]][0], source))
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    os.chdir(ROOT)
    code = pytest.main(["-x", "-q", "-n", "0", "-p", "no:cacheprovider", "-p", "no:randomly", "-k", DESELECT,
                        *MODULES[m["module"]][1]])
    os._exit(int(code))


def _start(m: dict, timeout_s: float, source: str | None = None):
    source = mutated_source(m) if source is None else source
    if source is None:
        return None
    pid = os.fork()
    if pid == 0:
        try:
            _child(m, source, timeout_s)
        finally:
            os._exit(4)
    return pid


def _outcome(status: int) -> str:
    code = os.waitstatus_to_exitcode(status)
    if code == 0:
        return "survived"
    if code == 3:
        return "killed (timeout)"
    if code == 5:  # pytest: no tests collected
        return "error: no tests"
    return "killed"


def _diff_line(m: dict) -> str:
    source = (ROOT / MODULES[m["module"]][0]).read_text(encoding="utf-8").splitlines()
    mutant = (mutated_source(m) or "").splitlines()
    for line in difflib.unified_diff(source, mutant, lineterm="", n=0):
        if line.startswith("+") and not line.startswith("+++"):
            return line[1:].strip()
    return ""


def summarise(results: dict) -> dict:
    """Kill rate per module and overall, with the binomial standard error of the sample."""
    per = {}
    for r in results.values():
        s = per.setdefault(r["module"], {"run": 0, "killed": 0})
        s["run"] += 1
        s["killed"] += r["outcome"].startswith("killed")
    total = {"run": sum(s["run"] for s in per.values()), "killed": sum(s["killed"] for s in per.values())}
    for s in [*per.values(), total]:
        p = s["killed"] / s["run"] if s["run"] else math.nan
        s["kill_rate"] = p
        s["std_error"] = math.sqrt(p * (1 - p) / s["run"]) if s["run"] else math.nan
    return {"modules": per, "total": total}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sample", type=int, default=60,
                   help="mutants drawn at random per module; 0 runs all (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="seed of the sample (default: %(default)s)")
    p.add_argument("--workers", type=int, default=2, help="mutants run at once (default: %(default)s)")
    p.add_argument("--timeout", type=float, default=120.0,
                   help="seconds before a mutant's tests count as hung, i.e. killed (default: %(default)s)")
    p.add_argument("--module", action="append", choices=sorted(MODULES),
                   help="only this module (repeatable; default: all)")
    p.add_argument("--lines", metavar="A-B", help="only mutants on lines A to B of the module (a change's lines)")
    p.add_argument("--retest", action="store_true",
                   help="run the survivors of an earlier run again (after the tests were improved)")
    p.add_argument("--out", type=Path, default=Path("runs/mutation.json"),
                   help="results, resumed from if present (default: %(default)s)")
    args = p.parse_args(argv)
    if args.sample < 0 or args.workers < 1 or args.timeout <= 0:
        print("mutation_test: error: --sample must be >= 0, --workers >= 1 and --timeout > 0", file=sys.stderr)
        return 2
    try:
        import cosmic_ray  # noqa: F401
    except ImportError:
        print("mutation_test: error: needs cosmic-ray: .venv/bin/pip install -e '.[mutation]'", file=sys.stderr)
        return 2
    # What every child needs, imported once here (the project itself is not: each child
    # imports it afresh around its mutant).
    import mujoco  # noqa: F401
    import numpy  # noqa: F401
    import pytest  # noqa: F401
    import scipy.linalg  # noqa: F401
    import scipy.optimize  # noqa: F401

    from jointrig.files import write_json_atomic

    modules = args.module or list(MODULES)
    plan = []
    counts = {}
    for mod in modules:
        every = enumerate_mutants(mod)
        if args.lines:
            lo, hi = (int(x) for x in args.lines.split("-"))
            every = [m for m in every if lo <= m["line"] <= hi]
        counts[mod] = len(every)
        rng = random.Random(f"{args.seed}:{mod}")
        plan += every if args.sample == 0 or args.sample >= len(every) else rng.sample(every, args.sample)
    done = {}
    if args.out.exists():
        old = json.loads(args.out.read_text())
        if old.get("sample") == args.sample and old.get("seed") == args.seed:
            done = old.get("results", {})
    todo = [m for m in plan if _key(m) not in done or (args.retest and done[_key(m)]["outcome"] == "survived")]
    # Control: each module's tests must pass with its unmutated source served the same way,
    # or every mutant would look killed.
    for mod in modules:
        original = (ROOT / MODULES[mod][0]).read_text(encoding="utf-8")
        _, status = os.waitpid(_start({"module": mod}, args.timeout, original), 0)
        if _outcome(status) != "survived":
            print(f"mutation_test: error: the tests of {mod} fail without any mutant ({_outcome(status)}); "
                  f"fix them first", file=sys.stderr)
            return 1
    print(f"{len(plan)} mutants ({', '.join(f'{m.split(chr(46))[-1]} {counts[m]}' for m in modules)} in all), "
          f"{len(plan) - len(todo)} done before, {len(todo)} to run on {args.workers} worker(s)", file=sys.stderr)

    planned = {_key(m) for m in plan}

    def save():
        # Results of mutants outside this plan (an earlier sample, other filters) stay in the
        # file for resuming but are not counted.
        counted = {k: v for k, v in done.items() if k in planned}
        write_json_atomic(args.out, {"sample": args.sample, "seed": args.seed, "operators": OPERATORS,
                                     "mutants_in_all": counts, "summary": summarise(counted), "results": done})

    running: dict[int, tuple[dict, float]] = {}
    t0 = time.perf_counter()
    queue = list(todo)
    while queue or running:
        while queue and len(running) < args.workers:
            m = queue.pop(0)
            pid = _start(m, args.timeout)
            if pid is None:
                done[_key(m)] = {**m, "outcome": "no mutation", "source": ""}
                continue
            running[pid] = (m, time.perf_counter())
        pid, status = os.wait()
        if pid not in running:
            continue
        m, started = running.pop(pid)
        outcome = _outcome(status)
        done[_key(m)] = {**m, "outcome": outcome, "seconds": round(time.perf_counter() - started, 2),
                         "source": _diff_line(m) if outcome == "survived" else ""}
        save()
        n = len(todo) - len(queue) - len(running)
        print(f"[{n}/{len(todo)}] {outcome:17s} {m['module'].split('.')[-1]}:{m['line']} {m['operator'].split('/')[-1]}"
              f"  ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    done = {k: v for k, v in done.items() if v["outcome"] != "no mutation"}
    save()
    counted = {k: v for k, v in done.items() if k in planned}
    s = summarise(counted)
    print(f"{'module':12s} {'mutants':>8s} {'run':>5s} {'killed':>7s} {'kill rate':>10s}")
    for mod, v in s["modules"].items():
        print(f"{mod.split('.')[-1]:12s} {counts[mod]:8d} {v['run']:5d} {v['killed']:7d} "
              f"{v['kill_rate']:6.1%} +- {v['std_error']:.1%}")
    t = s["total"]
    print(f"{'all':12s} {sum(counts.values()):8d} {t['run']:5d} {t['killed']:7d} {t['kill_rate']:6.1%} +- "
          f"{t['std_error']:.1%}")
    print("survivors:")
    for r in sorted(counted.values(), key=lambda r: (r["module"], r["line"])):
        if r["outcome"] == "survived":
            print(f"  {r['module'].split('.')[-1]}:{r['line']} {r['operator'].split('/')[-1]}: {r['source']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
