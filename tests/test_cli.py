"""The ``jointrig`` command: subcommands, --version, and --help that documents every option."""

import argparse
import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from jointrig import __version__
from jointrig.cli import SUBCOMMANDS, main


class _Parser(Exception):
    pass


def _parser_of(module_name: str, monkeypatch) -> argparse.ArgumentParser:
    """The subcommand's argument parser, caught as it is about to parse."""
    def grab(self, *args, **kwargs):
        raise _Parser(self)

    monkeypatch.setattr(argparse.ArgumentParser, "parse_known_args", grab)  # parse_args calls it too
    module = importlib.import_module(f"jointrig.commands.{module_name}")
    with pytest.raises(_Parser) as caught:
        module.main([])
    return caught.value.args[0]


@pytest.mark.parametrize("name", list(SUBCOMMANDS))
def test_every_option_has_help_with_its_default(name, monkeypatch):
    parser = _parser_of(SUBCOMMANDS[name][0], monkeypatch)
    missing = []
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        text = action.help or ""
        if not text:
            missing.append(f"{action.option_strings or action.dest}: no help")
        elif action.option_strings and action.default not in (None, False, argparse.SUPPRESS) \
                and "default" not in text:
            missing.append(f"{action.option_strings}: default {action.default!r} not shown")
    assert missing == []


def test_version_usage_and_unknown_subcommand(capsys):
    for flag in ("--version", "-V"):  # as every subcommand spells it
        assert main([flag]) == 0 and capsys.readouterr().out.strip() == f"jointrig {__version__}"
    assert main([]) == 2
    usage = capsys.readouterr().out
    assert all(name in usage for name in SUBCOMMANDS)
    assert main(["sweeep"]) == 2 and "unknown subcommand 'sweeep'" in capsys.readouterr().err


def test_python_dash_m_names_the_subcommand_in_its_usage():
    out = subprocess.run([sys.executable, "-m", "jointrig", "diagnose", "--help"], capture_output=True, text=True,
                         check=True).stdout
    assert out.startswith("usage: jointrig diagnose ")


@pytest.mark.parametrize("name, heavy", [
    ("diagnose", ("rerun", "matplotlib", "scipy.stats", "scipy.optimize", "mujoco", "dask", "pyarrow")),
    ("sweep", ("rerun", "matplotlib", "scipy.stats", "dask", "pyarrow")),
])
def test_help_answers_without_loading_the_numerical_stack(name, heavy):
    # `--help` and bad options must answer at once: the heavy packages (0.3-0.6 s each to
    # import) are loaded in main, after the arguments are parsed. The sweep needs MuJoCo for its
    # default plan's module; the diagnosis needs nothing of it.
    code = ("import sys\nfrom jointrig.cli import main\ntry:\n    main([%r, '--help'])\nexcept SystemExit:\n    pass\n"
            "print('loaded:' + ','.join(m for m in %r if m in sys.modules))" % (name, heavy))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.splitlines()[-1] == "loaded:", f"{name} --help {out.splitlines()[-1]}"


@pytest.mark.slow  # slow: a whole diagnosis of the README's example in a process of its own (about 55 s): a claim about the command's start-up cost
def test_the_diagnosis_imports_neither_a_gl_backend_nor_matplotlib(tmp_path):
    # MuJoCo's OpenGL backend (GLFW) would cost 0.05 s, and no command renders with MuJoCo
    # (jointrig.cli sets MUJOCO_GL=disable unless the user set it). The report's figures are SVG
    # written from the arrays (present/svg.py): matplotlib cost 1.7 s of CPU in every diagnosis
    # with --report. (scipy's optimize and special, 0.2 s of the start, are taken as they are:
    # a port of the one and a closed form of the other bought 8% of the worn example's command,
    # 2.45 s, and went.) A whole diagnosis of a small file with its report, in one process, then
    # what it loaded. The README's example file.
    data = Path(__file__).resolve().parent.parent / "examples" / "bench_dry_friction.csv"
    code = ("import sys\nfrom jointrig.cli import main\nassert main(['diagnose', %r, '-q', '--report', %r]) == 0\n"
            "print('loaded:' + ','.join(m for m in ('glfw', 'matplotlib') "
            "if m in sys.modules))" % (str(data), str(tmp_path / "r.html")))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**{k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}, "JOINTRIG_WORKERS": "1"}).stdout
    assert out.splitlines()[-1] == "loaded:", out.splitlines()[-1]


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: OpenBLAS's default pool is one thread already")
@pytest.mark.parametrize("user", [None, "2"])
def test_every_command_runs_with_one_blas_thread_unless_the_user_sized_the_pool(user):
    # jointrig.cli sets the pools before the command loads numpy (rig.runtime.limit_threads): the
    # environment variables for the libraries that load later (numpy's OpenBLAS here, scipy's
    # own after it) and for child processes. A pool size the user exported is kept. make-data is
    # a command that never set its pools itself; the parent's variables (conftest limits this
    # test session) are removed so the child starts as a user's shell would.
    code = ("import os, sys\nfrom jointrig.cli import main\ntry:\n    main(['make-data', '--help'])\nexcept SystemExit:\n"
            "    pass\nimport numpy, scipy.linalg\nfrom threadpoolctl import threadpool_info\n"
            "print(sorted({(i['internal_api'], i['num_threads']) for i in threadpool_info()}), "
            "os.environ.get('OPENBLAS_NUM_THREADS'))")
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    if user is not None:
        env["OPENBLAS_NUM_THREADS"] = user
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
    want = user or "1"
    assert out.splitlines()[-1] == f"[('openblas', {want})] {want}", out
