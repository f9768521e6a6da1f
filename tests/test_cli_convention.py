"""One command-line convention for every subcommand (issue 37): ``-q`` and ``-V`` everywhere,
help examples written as ``jointrig ...`` (``python3 scripts/...`` fails outside the venv), and
no default printed as an absolute path of one machine."""

from __future__ import annotations

import pytest

from jointrig import __version__
from jointrig.cli import SUBCOMMANDS, main


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
    for module in (diagnose, diagnose_chain):
        assert "unexplained" not in module.__doc__.split("Exit status")[1].split(".")[0], module.__doc__


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
