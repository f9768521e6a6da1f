"""Outputs and stores a user may not write: refused before any work, exit 2, no traceback.

Every output file (JSON, HTML report, card JSON/PNG, MJCF, rerun recording, measured runs) and
every store (sweep and chain stores) is checked by one helper
(:func:`jointrig.commands.options.check_output`, :func:`~jointrig.commands.options.check_folder`)
as the user running the command meets it. The permission cases are run as that user: the CLI in
a subprocess under uid/gid 65534 (``nobody``) when the tests run as root, in a world-accessible
folder of files owned by root (another user's); they are skipped, with the reason, where no
interpreter can be started as ``nobody``. A read-only file system is a real read-only bind mount
where the machine allows one (``unshare -m``, root), and the check function with a write failing
with EROFS otherwise. Each command stops at the check: the smallest shipped example would take
seconds to diagnose, the refusals take the CLI's start-up.
"""

from __future__ import annotations

import errno
import functools
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from jointrig.commands.options import BadArgument, check_folder, check_output

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "bench_dry_friction.csv"
NOBODY = 65534

# ---------------------------------------------------------------- running the CLI as another user


def _drop_to_nobody():
    os.setgroups([])
    os.setgid(NOBODY)
    os.setuid(NOBODY)


_BOOT = ("import site, sys\n"
         "for d in sys.argv[1].split(':'):\n"
         "    site.addsitedir(d)\n"
         "from jointrig.cli import main\n"
         "sys.argv = ['jointrig'] + sys.argv[2:]\n"
         "sys.exit(main())\n")


@functools.lru_cache(maxsize=1)
def _as_user() -> tuple:
    """(command prefix, preexec_fn) that runs ``jointrig`` as an unprivileged user, or a reason
    why none can be (a string). As root: this interpreter if ``nobody`` may start it, else the
    system's interpreter of the same version (the project's own may live under /root, mode 0700)
    with this environment's site-packages; as another user: that user already."""
    import site

    if os.geteuid() != 0:
        return ([sys.executable, "-m", "jointrig"], None)
    if not hasattr(os, "setuid"):
        return "no setuid on this platform"
    sites = ":".join(site.getsitepackages())
    v = sys.version_info
    for exe in (sys.executable, f"/usr/bin/python{v.major}.{v.minor}", f"/usr/local/bin/python{v.major}.{v.minor}"):
        if not os.path.exists(exe):
            continue
        cmd = [exe, "-I", "-c", _BOOT, sites]
        try:
            done = subprocess.run([*cmd, "--version"], preexec_fn=_drop_to_nobody, capture_output=True, text=True,
                                  cwd="/", env=_env("/tmp"), timeout=60)
        except (OSError, subprocess.SubprocessError):
            continue
        if done.returncode == 0 and done.stdout.startswith("jointrig"):
            return (cmd, _drop_to_nobody)
    return (f"no Python {v.major}.{v.minor} that uid {NOBODY} may start imports jointrig here "
            f"({sys.executable} is not reachable by other users)")


def _env(home) -> dict:
    keep = {k: v for k, v in os.environ.items() if k in ("PATH", "LANG", "LC_ALL", "TZ")}
    return {**keep, "HOME": str(home), "XDG_CACHE_HOME": str(Path(home) / ".cache"),
            "MPLCONFIGDIR": str(Path(home) / ".mpl"), "JOINTRIG_WORKERS": "1", "MUJOCO_GL": "disable"}


@pytest.fixture
def world():
    """A folder every user may enter and write in (pytest's tmp_path is root's, mode 0700),
    holding the shipped example; removed afterwards."""
    how = _as_user()
    if isinstance(how, str):
        pytest.skip(how)
    d = Path(tempfile.mkdtemp(prefix="jointrig-unwritable-"))
    try:
        os.chmod(d, 0o777)
        shutil.copy(EXAMPLE, d / "data.csv")
        os.chmod(d / "data.csv", 0o644)
        yield d
    finally:
        for p in d.rglob("*"):  # a read-only folder's contents are removable only once it is writable
            if p.is_dir() and not p.is_symlink():
                os.chmod(p, 0o755)
        shutil.rmtree(d)


def _jointrig(world: Path, *args: str) -> subprocess.CompletedProcess:
    cmd, preexec = _as_user()
    home = world / "home"
    home.mkdir(exist_ok=True)
    os.chmod(home, 0o777)
    return subprocess.run([*cmd, *args], preexec_fn=preexec, cwd=world, capture_output=True, text=True,
                          env=_env(home), timeout=120)


def _listing(d: Path) -> list:
    return sorted(str(p.relative_to(d)) for p in d.rglob("*") if "home" not in p.relative_to(d).parts)


def _refused(world: Path, args: list, *expected: str) -> str:
    """Run ``jointrig *args`` as the user: exit 2, each of ``expected`` in the message, no
    traceback, no diagnosis printed, and nothing written anywhere in ``world``."""
    before = _listing(world)
    done = _jointrig(world, *args)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    for text in expected:
        assert text in done.stderr, done.stderr
    assert done.stdout == "", done.stdout  # stopped before the work
    assert _listing(world) == before
    return done.stderr


def _locked(world: Path) -> Path:
    """A folder of root's that others may read but not write in (mode 0555)."""
    d = world / "locked"
    d.mkdir()
    os.chmod(d, 0o555)
    return d


# ------------------------------------------------------------------ a folder the user may not write in

CANNOT_WRITE = "cannot create a file in locked (Permission denied): expected a folder you may write in"


def test_make_data_into_a_folder_the_user_may_not_write(world):
    _locked(world)
    _refused(world, ["make-data", "locked/x.csv"], f"out locked/x.csv: {CANNOT_WRITE}", "write elsewhere")


@pytest.mark.parametrize("option", ["--json", "--report", "--rrd", "--card", "--card-png", "--mjcf"])
def test_diagnose_outputs_into_a_folder_the_user_may_not_write(world, option):
    _locked(world)
    _refused(world, ["diagnose", "data.csv", option, "locked/out.x"], f"{option} locked/out.x: {CANNOT_WRITE}",
             "ask the owner of locked")


@pytest.mark.parametrize("option", ["--json", "--png"])
def test_card_outputs_into_a_folder_the_user_may_not_write(world, option):
    _locked(world)
    err = _refused(world, ["card", "data.csv", option, "locked/card.x"], f"{option} locked/card.x: {CANNOT_WRITE}")
    assert "--card" not in err  # this command's option is named, not diagnose's


def test_chain_store_in_a_folder_the_user_may_not_write(world):
    _locked(world)
    _refused(world, ["diagnose-chain", "--no-rrd", "--json", "c.json", "--store", "locked/store"],
             f"--store locked/store: {CANNOT_WRITE}")


def test_sweep_store_and_default_store_the_user_may_not_write(world):
    _locked(world)
    _refused(world, ["sweep", "--store", "locked/store"], f"--store locked/store: {CANNOT_WRITE}")
    # no --store: the default runs/store/<model>-<hash>, checked before the sweep too
    (world / "runs").mkdir()
    os.chmod(world / "runs", 0o555)
    _refused(world, ["sweep", "--json", "s.json", "--no-rrd"], "--store runs/store/",
             "cannot create a file in runs (Permission denied)")


@pytest.mark.parametrize("command", [["design"], ["unknown-law"], ["paper"], ["cases"], ["card-check"]],
                         ids=lambda c: c[0])
def test_other_commands_json_into_a_folder_the_user_may_not_write(world, command):
    _locked(world)
    option = "--png" if command == ["unknown-law"] else "--json"
    _refused(world, [*command, option, "locked/o.x"], f"{option} locked/o.x: {CANNOT_WRITE}")


# -------------------------------------------------- an existing file or a folder of another user

def test_an_existing_read_only_file_of_another_user(world):
    (world / "d.json").write_text("{}\n")
    os.chmod(world / "d.json", 0o444)
    _refused(world, ["diagnose", "data.csv", "--json", "d.json"], "--json d.json: exists and is not writable",
             "mode 0444", "expected a file you may replace", "or write elsewhere")
    assert (world / "d.json").read_text() == "{}\n"


def test_another_users_file_in_a_sticky_folder(world):
    # /tmp's rule: a writable file of another user cannot be renamed over (the atomic write's way)
    sticky = world / "shared"
    sticky.mkdir()
    os.chmod(sticky, 0o1777)
    (sticky / "r.html").write_text("old")
    os.chmod(sticky / "r.html", 0o666)
    _refused(world, ["diagnose", "data.csv", "--report", "shared/r.html"],
             "--report shared/r.html: exists and is another user's (uid 0) in shared, a folder with the sticky bit")


def test_a_folder_the_user_may_not_enter(world):
    private = world / "private"
    private.mkdir()
    os.chmod(private, 0o700)
    _refused(world, ["make-data", "private/x.csv"], "out private/x.csv: cannot be reached (Permission denied",
             "private (uid 0, mode 0700) cannot be entered")
    _refused(world, ["diagnose-chain", "--no-rrd", "--json", "c.json", "--store", "private/st"],
             "--store private/st: cannot be reached")


# ---------------------------------------------------- a file where a folder is expected, and back

def test_a_file_given_as_the_chain_store(world):
    (world / "good.csv").write_text("x\n")
    _refused(world, ["diagnose-chain", "--no-rrd", "--json", "c.json", "--store", "good.csv"],
             "--store good.csv: is a file; expected a folder", "name a new or an existing folder")


def test_a_file_in_the_chain_stores_place_of_its_runs(world):
    (world / "st").mkdir()
    os.chmod(world / "st", 0o777)  # a store the user may write in, but its runs' folder is a file
    (world / "st" / "estimation").write_text("x\n")
    _refused(world, ["diagnose-chain", "--no-rrd", "--json", "c.json", "--store", "st"],
             "--store st/estimation: is a file; expected a folder")


def test_a_file_on_the_way_to_an_output(world):
    (world / "good.csv").write_text("x\n")
    _refused(world, ["make-data", "good.csv/x.csv"], "good.csv is a file, not a folder: expected a file inside a folder")
    _refused(world, ["sweep", "--store", "good.csv/s"], "good.csv is a file, not a folder: expected a folder inside")


def test_a_folder_given_as_an_output_file(world):
    (world / "out.csv").mkdir()
    _refused(world, ["make-data", "out.csv"], "out out.csv: is a folder; expected a file path")
    _refused(world, ["diagnose", "data.csv", "--mjcf", "out.csv"], "--mjcf out.csv: is a folder; expected a file path")


# ------------------------------------------------------------------------ a read-only file system

def test_a_read_only_file_system(tmp_path):
    # A real read-only mount where this machine allows one (root, a private mount namespace).
    if os.geteuid() != 0 or not shutil.which("unshare") or not shutil.which("mount"):
        pytest.skip("a read-only mount needs root and unshare here; see test_the_check_on_a_read_only_file_system")
    ro = tmp_path / "ro"
    (ro / "sub").mkdir(parents=True)
    (ro / "d.json").write_text("{}")
    script = (f"mount --bind {ro} {ro} && mount -o remount,bind,ro {ro} || exit 99; "
              f"{sys.executable} -m jointrig diagnose {EXAMPLE} --json {ro}/d.json; echo rc=$?; "
              f"{sys.executable} -m jointrig make-data {ro}/sub/x.csv; echo rc=$?; "
              f"{sys.executable} -m jointrig diagnose-chain --no-rrd --json {tmp_path}/c.json --store {ro}/st; "
              f"echo rc=$?")
    done = subprocess.run(["unshare", "-m", "sh", "-c", script], capture_output=True, text=True, timeout=120)
    if done.returncode == 99 or "rc=" not in done.stdout:
        pytest.skip(f"no read-only mount here: {done.stderr.strip()[:200]}")
    assert done.stdout.count("rc=2") == 3, (done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    assert f"--json {ro}/d.json: exists on a read-only file system" in done.stderr
    assert f"out {ro}/sub/x.csv: cannot create a file in {ro}/sub (Read-only file system): expected a writable " \
           f"file system" in done.stderr
    assert f"--store {ro}/st: cannot create a file in {ro} (Read-only file system)" in done.stderr
    assert sorted(p.name for p in ro.rglob("*")) == ["d.json", "sub"] and not (tmp_path / "c.json").exists()


def test_the_check_on_a_read_only_file_system(tmp_path, monkeypatch):
    # The check function itself, wherever the machine allows no mount: every create fails EROFS.
    def read_only(*a, **k):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    with pytest.raises(BadArgument, match=r"--json .*/o\.json: cannot create a file in .* \(Read-only file system\): "
                                          r"expected a writable file system; write on another one"):
        check_output(tmp_path / "o.json", "--json")
    with pytest.raises(BadArgument, match=r"--store .*/st: cannot create a file in .* \(Read-only file system\)"):
        check_folder(tmp_path / "st", "--store")
    monkeypatch.undo()

    (tmp_path / "old.json").write_text("{}")

    class Flags:
        f_flag = os.ST_RDONLY

    monkeypatch.setattr(os, "access", lambda *a, **k: False)
    monkeypatch.setattr(os, "statvfs", lambda *a, **k: Flags)
    with pytest.raises(BadArgument, match=r"old\.json: exists on a read-only file system: expected a file you may "
                                          r"replace; write on another file system"):
        check_output(tmp_path / "old.json", "--json")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.json"]


def test_an_atomic_write_whose_folder_cannot_be_made_is_named(tmp_path):
    # Past the check (a folder replaced by a file meanwhile): an OutputError naming the file, no traceback.
    from jointrig.files import OutputError, write_atomic

    (tmp_path / "gone").write_text("a file now")
    with pytest.raises(OutputError, match=r"gone/o\.json: could not be written"):
        write_atomic(tmp_path / "gone" / "o.json", lambda tmp: tmp.write_text("{}"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gone"]
