"""One command-line convention for every subcommand (issue 37): ``-q`` and ``-V`` everywhere,
help examples written as ``jointrig ...`` (``python3 scripts/...`` fails outside the venv), and
no default printed as an absolute path of one machine."""

from __future__ import annotations

from pathlib import Path

import pytest

from jointrig import __version__
from jointrig.cli import SUBCOMMANDS, main

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("name", list(SUBCOMMANDS))
def test_every_subcommand_has_quiet_version_and_portable_help(name, capsys):
    with pytest.raises(SystemExit) as exit_:
        main([name, "--help"])
    assert exit_.value.code == 0
    text = capsys.readouterr().out
    assert "-q, --quiet" in text and "-V, --version" in text, text
    assert "python3 scripts/" not in text and "python scripts/" not in text
    assert "/work/" not in text and "/home/" not in text and "/root/" not in text
    for flag in ("-V", "--version"):
        with pytest.raises(SystemExit) as exit_:
            main([name, flag])
        assert exit_.value.code == 0 and capsys.readouterr().out.strip() == f"jointrig {__version__}"


@pytest.mark.parametrize("name", ["sweep", "unknown-law", "design", "cases", "card-check", "diagnose-chain", "paper"])
def test_the_noise_level_is_one_option_name(name, capsys):
    # --snr-db in every subcommand that adds noise (the sweep's and the unknown law's old
    # --noise-db is still read, as an alias)
    with pytest.raises(SystemExit):
        main([name, "--help"])
    text = capsys.readouterr().out
    assert "--snr-db" in text, text


def test_held_out_runs_are_one_option_name_and_a_verdict_is_no_error(capsys):
    # issue 53: --holdout in every subcommand that holds runs out (diagnose-chain had --held-out),
    # and the verdict is what the command reports, not its exit status: both diagnoses document
    # 0 for any verdict, 2 for bad input, 1 for a failed identification.
    import re

    from jointrig.commands import diagnose, diagnose_chain

    names = {}
    for name in SUBCOMMANDS:
        with pytest.raises(SystemExit):
            main([name, "--help"])
        names[name] = set(re.findall(r"--[a-z][a-z-]*", capsys.readouterr().out))
    assert not any("--held-out" in n for n in names.values()), {k for k, n in names.items() if "--held-out" in n}
    assert {"diagnose", "diagnose-chain", "card"} <= {k for k, n in names.items() if "--holdout" in n}
    from jointrig.commands import EXIT_STATUS

    assert "0 when the job ran, whatever its verdict" in EXIT_STATUS
    for module in (diagnose, diagnose_chain):  # the rule is stated once, in every help's end
        assert "Exit status" not in module.__doc__, module.__doc__


def test_quiet_before_the_subcommand_is_the_subcommands(monkeypatch, capsys):
    # issue 53: -q at every level, as -V: `jointrig -q diagnose DATA` is `jointrig diagnose DATA -q`
    from jointrig.commands import options

    seen = []
    monkeypatch.setattr(options, "run_cli", lambda fn, prog, argv: seen.append((prog, list(argv))) or 0)
    assert main(["-q", "diagnose", "data.csv", "--json", "d.json"]) == 0
    assert main(["--quiet", "make-data", "out.csv"]) == 0
    assert seen == [("jointrig diagnose", ["data.csv", "--json", "d.json", "-q"]),
                    ("jointrig make-data", ["out.csv", "-q"])]
    assert main(["-q"]) == 2 and "usage: jointrig [-V | --version] [-q | --quiet]" in capsys.readouterr().err


def test_ctrl_c_is_a_line_and_exit_130_not_a_traceback(capsys):
    from jointrig.commands.options import run_cli

    def interrupted(argv):
        raise KeyboardInterrupt

    assert run_cli(interrupted, "jointrig diagnose", []) == 130
    err = capsys.readouterr().err
    assert "jointrig diagnose: interrupted" in err and "Traceback" not in err


def _help(name, capsys) -> str:
    with pytest.raises(SystemExit):
        main([name, "--help"])
    return capsys.readouterr().out


def _example(text: str) -> str:
    """The example command a help text ends with (the line after the last "Example" line)."""
    lines = text.rstrip().splitlines()
    at = max(i for i, line in enumerate(lines) if line.startswith("Example ("))
    assert at == len(lines) - 2, f"the help does not end with one example line: {lines[at:]}"
    return lines[-1].strip()


@pytest.mark.parametrize("name", list(SUBCOMMANDS))
def test_every_help_ends_with_the_exit_status_and_an_example_on_shipped_files(name, capsys):
    # issue 53: one exit-status rule stated in every help, and an example that names files the
    # repository ships (the examples run as printed below)
    from jointrig.commands import EXIT_STATUS

    text = _help(name, capsys)
    assert " ".join(text.split()).count(EXIT_STATUS) == 1, text
    example = _example(text)
    assert example.startswith(f"jointrig {name}"), example
    for token in example.split():
        if token.startswith(("models/", "examples/")):
            assert (ROOT / token).is_file(), f"{name}'s example names {token}, which the repository does not ship"


def test_the_commands_on_your_data_come_first_in_the_usage(capsys):
    from jointrig.cli import ON_YOUR_DATA

    assert main(["--help"]) == 0
    usage = capsys.readouterr().out
    first_demo = min(usage.index(f"  {n} ") for n in SUBCOMMANDS if n not in ON_YOUR_DATA)
    assert all(usage.index(f"  {n} ") < first_demo for n in ON_YOUR_DATA), usage
    assert usage.rstrip().endswith("jointrig diagnose examples/bench_dry_friction.csv")


#: the examples that take minutes (a diagnosis, or every hidden-effect case), and those whose whole
#: job the fast suite runs already (the Silverbox path, tests/test_silverbox.py, 25 s; the card
#: against phase resonance, tests/test_card.py, 15 s): run by ``-m slow``
SLOW_EXAMPLES = ("diagnose", "card", "diagnose-chain", "cases", "silverbox", "card-check")


def _needs(name):
    marks = [pytest.mark.slow] if name in SLOW_EXAMPLES else []
    if name == "silverbox":
        from jointrig.measured.silverbox import DEFAULT_DIR

        marks.append(pytest.mark.skipif(not (DEFAULT_DIR / "SNLS80mV.csv").is_file(),
                                        reason=f"Silverbox data not at {DEFAULT_DIR}"))
    return pytest.param(name, marks=marks)


@pytest.mark.parametrize("name", [_needs(n) for n in SUBCOMMANDS])
def test_every_helps_example_runs_as_printed(name, capsys, tmp_path):
    # in a folder laid out as the repository (its models/ and examples/), as a user runs it; every
    # file the example writes (runs/...) is there afterwards
    import shlex
    import subprocess
    import sys

    example = _example(_help(name, capsys))
    for folder in ("models", "examples"):
        (tmp_path / folder).symlink_to(ROOT / folder)
    argv = shlex.split(example)[1:]
    # the timeout catches a hang, not a slow machine: `cases` takes 6 min alone on 2 cores and
    # twice that beside the slow tier's other worker (its speed: scripts/bench_*.py)
    done = subprocess.run([sys.executable, "-m", "jointrig", *argv, "-q"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=2400)
    assert done.returncode == 0, f"{example}: exit {done.returncode}\n{done.stderr[-2000:]}"
    for token in argv:
        if token.startswith("runs/"):
            assert (tmp_path / token).is_file(), f"{example} did not write {token}"
