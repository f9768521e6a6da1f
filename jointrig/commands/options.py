"""What every command checks and how it runs: its options' ranges and outputs, checked before
any work (a bad one is a :class:`BadArgument`, exit 2, naming the option), the run itself
(:func:`run_cli`: exit codes, no traceback), its progress level and the callback backend option."""

from __future__ import annotations

__all__ = ["BadArgument", "check_output", "check_folder", "check_range", "check_each", "run_cli", "progress_level",
           "add_backend_option"]


class BadArgument(ValueError):
    """A command-line argument that cannot be used (names the option and what was expected)."""


# Every output a command writes (a file: JSON, HTML, PNG, MJCF, rerun recording, measured runs)
# and every store it keeps (a folder: sweep points) is checked here, before any work, as the user
# running the command meets it: no permission, a read-only file system, a file where a folder is
# expected, a folder where a file is expected, a folder that cannot be entered. Each refusal is a
# BadArgument (exit 2) naming the option, the path, what was expected and the fix; the check
# writes nothing but a probe file it removes at once. The outputs themselves are then written
# atomically (jointrig.files.write_atomic).


def _fix(err: OSError, place) -> str:
    """Why no file can be created in ``place`` (the OSError of the attempt), and the fix."""
    import errno

    code = getattr(err, "errno", None)
    if code == errno.EROFS:
        return "expected a writable file system; write on another one (e.g. under your home folder)"
    if code in (errno.EACCES, errno.EPERM):
        return (f"expected a folder you may write in; write elsewhere (e.g. under your home folder), or ask the "
                f"owner of {place}{_owner(place)} for write permission")
    if code in (errno.ENOSPC, errno.EDQUOT):
        return "expected room for the output; free space (or quota) or write elsewhere"
    return "expected a folder a file can be created in; write elsewhere"


def _owner(path) -> str:
    """`` (uid N, mode 0755)`` of ``path``, or nothing where it cannot be read."""
    import os

    try:
        st = os.stat(path)
    except OSError:
        return ""
    return f" (uid {st.st_uid}, mode {st.st_mode & 0o7777:04o})"


def _probe_writable(option: str, p, what: str, expected: str = "a file") -> None:
    """Refuse ``p`` (an output file's folder or an output folder) unless a file can be created in
    it, or in the nearest existing folder above it (probed by creating and removing one)."""
    import os
    import tempfile

    place = p
    while not place.exists():
        place = place.parent
    if not place.is_dir():
        raise BadArgument(f"{option} {what}: {place} is a file, not a folder: expected {expected} inside a folder; "
                          f"choose another path")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".jointrig-probe.", dir=place)
        os.close(fd)
        os.unlink(tmp)
    except OSError as err:
        raise BadArgument(f"{option} {what}: cannot create a file in {place} ({err.strerror}): "
                          f"{_fix(err, place)}") from None


def _replaceable(option: str, p) -> None:
    """Refuse an existing output file the user may not replace: not writable (its mode, a
    read-only file system), or another user's in a folder with the sticky bit (like /tmp,
    where only a file's owner may rename over it)."""
    import os
    import stat

    if not os.access(p, os.W_OK):
        try:
            read_only = bool(os.statvfs(p).f_flag & os.ST_RDONLY)
        except OSError:
            read_only = False
        if read_only:
            raise BadArgument(f"{option} {p}: exists on a read-only file system: expected a file you may replace; "
                              f"write on another file system (e.g. under your home folder)")
        raise BadArgument(f"{option} {p}: exists and is not writable{_owner(p)}: expected a file you may replace; "
                          f"make it writable (chmod u+w {p}, if it is yours), remove it, or write elsewhere")
    st, folder = os.stat(p), os.stat(p.parent)
    me = os.geteuid()
    if folder.st_mode & stat.S_ISVTX and me not in (0, st.st_uid, folder.st_uid):
        raise BadArgument(f"{option} {p}: exists and is another user's (uid {st.st_uid}) in {p.parent}, a folder with "
                          f"the sticky bit (like /tmp), where only its owner may replace it: expected a file you may "
                          f"replace; write under another name or elsewhere")


def check_output(path, option: str) -> None:
    """Refuse an output file's path before any work: a folder, an existing file the user may not
    replace, or a place where no file can be created (probed in the nearest existing folder): a
    :class:`BadArgument` naming ``option``, the path, what was expected and the fix."""
    from pathlib import Path

    if path is None:
        return
    p = Path(path)
    try:
        if p.is_dir():
            raise BadArgument(f"{option} {p}: is a folder; expected a file path: name a file (in that folder "
                              f"or elsewhere), not a folder")
        if p.exists():
            _replaceable(option, p)
        _probe_writable(option, p.parent, str(p), "a file")
    except OSError as err:  # a folder on the way that cannot be entered, a name too long
        raise _unreachable(option, p, err, "a file") from None


def check_folder(path, option: str) -> None:
    """Refuse an output folder (a store) before any work: a file in its place or on its way, or a
    place where the folder cannot be made or written (probed in it, or in the nearest existing
    folder above it)."""
    from pathlib import Path

    if path is None:
        return
    p = Path(path)
    try:
        if p.exists() and not p.is_dir():
            raise BadArgument(f"{option} {p}: is a file; expected a folder: name a new or an existing folder, "
                              f"not a file")
        _probe_writable(option, p, str(p), "a folder")
    except OSError as err:
        raise _unreachable(option, p, err, "a folder") from None


def _unreachable(option: str, p, err: OSError, expected: str) -> BadArgument:
    """The refusal of a path whose folders cannot even be looked into (``err`` of the look)."""
    import os

    blocked = next((d for d in reversed(p.absolute().parents) if not os.access(d, os.X_OK)), None)
    where = f"; the folder {blocked}{_owner(blocked)} cannot be entered" if blocked is not None else ""
    return BadArgument(f"{option} {p}: cannot be reached ({err.strerror or err}{where}): expected {expected} in a "
                       f"folder you may enter and write in; write elsewhere (e.g. under your home folder)")


def refused(parser, *checks) -> None:
    """Run each check (callables raising :class:`BadArgument`); the first refusal exits 2 with its
    message through ``parser`` (an ``argparse`` parser): a script's options checked as the
    commands check theirs."""
    try:
        for check in checks:
            check()
    except BadArgument as err:
        parser.exit(2, f"{parser.prog}: error: {err}\n")


def study_outputs(parser, out, levels_db, json_path) -> None:
    """A coverage study's options checked before its work (exit 2 through ``parser``): its
    folder of per-case files ``out`` (created), its noise levels, its summary file."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        parser.exit(2, f"{parser.prog}: error: cannot use --out {out}: {err.strerror}\n")
    refused(parser, lambda: check_levels_db(levels_db), lambda: check_output(json_path, "--json"))


def check_levels_db(levels, option: str = "--db") -> None:
    """Refuse a noise level (SNR in dB per channel) outside (0, 200]."""
    for d in levels:
        check_range(d, option, lo=0.0, hi=200.0, lo_open=True)


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
    Ctrl-C exits 130 (the shell's code for SIGINT) with a line, not a traceback: every output is
    written to a temporary file and renamed when whole, so none is left half written."""
    import sys

    try:
        return main(argv)
    except KeyboardInterrupt:
        print(f"\n{name}: interrupted; no output was left half written (each is renamed into place "
              f"only when whole; a sweep with a store resumes from it)", file=sys.stderr)
        return 130
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
    the native C callback wherever it can run; its records are the Python one's to 1e-8 of their
    peak), passed on as
    the simulations' ``backend``, and ``--native``, kept as its old spelling."""
    from jointrig.rig.native_callback import BACKENDS

    g = parser.add_mutually_exclusive_group()
    g.add_argument("--backend", choices=BACKENDS, default="auto",
                   help="the joint law's callback: native (C, compiled on first use; the same numbers, 3-5x "
                        "faster), python, or auto: native wherever a C compiler builds it and it knows every "
                        "term, else python (default: %(default)s)")
    g.add_argument("--native", dest="backend", action="store_const", const="native",
                   help="same as --backend native")
