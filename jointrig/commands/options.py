"""What every command checks and how it runs: its options' ranges and outputs, checked before
any work (a bad one is a :class:`BadArgument`, exit 2, naming the option), the run itself
(:func:`run_cli`: exit codes, no traceback), its progress level and the callback backend option."""

from __future__ import annotations

__all__ = ["BadArgument", "check_output", "check_folder", "check_range", "check_each", "run_cli", "progress_level",
           "add_backend_option"]


class BadArgument(ValueError):
    """A command-line argument that cannot be used (names the option and what was expected)."""


def _probe_writable(option: str, p, what: str) -> None:
    """Refuse ``p`` (an output file's folder or an output folder) unless a file can be created in
    it, or in the nearest existing folder above it (probed by creating and removing one)."""
    import os
    import tempfile

    place = p
    while not place.exists():
        place = place.parent
    if not place.is_dir():
        raise BadArgument(f"{option} {what}: {place} is a file, not a folder")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".jointrig-probe.", dir=place)
        os.close(fd)
        os.unlink(tmp)
    except OSError as err:
        raise BadArgument(f"{option} {what}: cannot create a file in {place} ({err.strerror})") from None


def check_output(path, option: str) -> None:
    """Refuse an output path before any work: a directory, or a place where no file can be
    created (probed in the nearest existing folder)."""
    import os
    from pathlib import Path

    if path is None:
        return
    p = Path(path)
    if p.exists() and p.is_dir():
        raise BadArgument(f"{option} {p}: is a folder; expected a file path")
    if p.exists() and not os.access(p, os.W_OK):
        raise BadArgument(f"{option} {p}: exists and is not writable")
    _probe_writable(option, p.parent, str(p))


def check_folder(path, option: str) -> None:
    """Refuse an output folder before any work: a file in its place, or a place where the folder
    cannot be made or written (probed in it, or in the nearest existing folder above it)."""
    from pathlib import Path

    if path is None:
        return
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise BadArgument(f"{option} {p}: is a file; expected a folder")
    _probe_writable(option, p, str(p))


def check_range(value, option: str, *, lo=None, hi=None, lo_open=False, hi_open=False, integer=False) -> None:
    """Refuse a numeric option outside [lo, hi] (open ends where asked), or not finite."""
    import math

    ok = isinstance(value, (int, float)) and math.isfinite(value)
    if integer:
        ok = ok and float(value).is_integer()
    if ok and lo is not None:
        ok = value > lo if lo_open else value >= lo
    if ok and hi is not None:
        ok = value < hi if hi_open else value <= hi
    if not ok:
        def num(x):
            return str(x) if integer else f"{x:g}"

        lo_s = "" if lo is None else ("(" if lo_open else "[") + num(lo)
        hi_s = "" if hi is None else num(hi) + (")" if hi_open else "]")
        kind = "an integer" if integer else "a number"
        rng = f" in {lo_s or '(-inf'}, {hi_s or 'inf)'}"
        raise BadArgument(f"{option} {value!r}: expected {kind}{rng}")


def check_each(values, option: str, **bounds) -> None:
    """:func:`check_range` on every value of a list option (``--omegas 10 45 90``)."""
    for v in values:
        check_range(v, option, **bounds)


def run_cli(main, name: str, argv=None) -> int:
    """Run a command's ``main``: bad input (a ``ValueError``: the message names the file,
    option or field) exits 2 with the message; a failed simulation (``RuntimeError``) exits 1;
    neither prints a traceback."""
    import sys

    try:
        return main(argv)
    except BrokenPipeError:
        # The reader went away (``jointrig diagnose DATA | head``): not an error of the command.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except ValueError as err:
        print(f"{name}: error: {err}", file=sys.stderr)
        return 2
    except RuntimeError as err:
        print(f"{name}: failed: {err}", file=sys.stderr)
        return 1


def progress_level(quiet: bool) -> int:
    """Logging level of a command's progress lines (on stderr): INFO on a terminal, WARNING under
    ``--quiet`` or when stderr is not a terminal (a log file or a CI job gets the results, not
    the progress), unless ``JOINTRIG_PROGRESS=1`` asks for them."""
    import logging
    import os
    import sys

    if quiet:
        return logging.WARNING
    if os.environ.get("JOINTRIG_PROGRESS") == "1" or sys.stderr.isatty():
        return logging.INFO
    return logging.WARNING


def add_backend_option(parser) -> None:
    """``--backend {auto,native,python}`` (:data:`rig.native_callback.BACKENDS`; default auto:
    the native C callback wherever it can run, bit-identical to the Python one), passed on as
    the simulations' ``backend``, and ``--native``, kept as its old spelling."""
    from jointrig.rig.native_callback import BACKENDS

    g = parser.add_mutually_exclusive_group()
    g.add_argument("--backend", choices=BACKENDS, default="auto",
                   help="the joint law's callback: native (C, compiled on first use; the same numbers, 3-5x "
                        "faster), python, or auto: native wherever a C compiler builds it and it knows every "
                        "term, else python (default: %(default)s)")
    g.add_argument("--native", dest="backend", action="store_const", const="native",
                   help="same as --backend native")
