"""Results written so that nothing is lost: every file goes to a temporary name beside its
place and is renamed into it (``os.replace``), so an interrupted command leaves the old file or
the new one, never half of one, and no temporary file behind."""

from __future__ import annotations

import contextlib
import errno
import glob
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Callable

__all__ = ["OutputError", "write_atomic", "write_json_atomic", "readable_mode", "temp_beside", "output_failed"]


class OutputError(ValueError):
    """An output could not be written (a full disk, a folder that went away): the message names
    the file and says that nothing half-written was left (exit 2, as bad input: the user fixes
    where the output goes)."""


def output_failed(path: Path, err: BaseException) -> OutputError:
    """The clear error for a write of ``path`` that failed with ``err``."""
    fix = "write elsewhere"
    if isinstance(err, OSError) and err.errno == errno.ENOSPC:
        why, fix = "no space left on the device", "free space or write elsewhere"
    elif isinstance(err, OSError):
        why = err.strerror or str(err)
        if err.errno in (errno.EACCES, errno.EPERM):
            fix = "write where you may (e.g. under your home folder), or ask the folder's owner for write permission"
        elif err.errno == errno.EROFS:
            fix = "write on another file system (e.g. under your home folder)"
    else:
        why = str(err)
    return OutputError(f"{path}: could not be written ({why}); nothing half-written was left there (an older file of "
                       f"that name is unchanged): {fix}")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def temp_beside(path: Path) -> Path:
    """A new temporary file beside ``path`` (``.NAME.PID.XXXX.tmp``), after removing those an
    earlier process left when it was killed (their PID is gone): a SIGKILL while writing leaves
    its temporary file, and the next run cleans it up."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    for old in path.parent.glob(f".{glob.escape(path.name)}.*.tmp"):
        pid = old.name[len(path.name) + 2:].split(".", 1)[0]
        if pid.isdigit() and not _alive(int(pid)):
            with contextlib.suppress(OSError):
                old.unlink()
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    return Path(tmp)


def write_atomic(path: Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it into place. A
    write that fails for want of space (or any other OSError) removes the temporary file and
    raises :class:`OutputError` naming ``path``."""
    path = Path(path)
    tmp = None
    try:
        tmp = temp_beside(path)  # its folder made here: a failure to is named as the write's
        write(tmp)
        os.chmod(tmp, readable_mode())
        os.replace(tmp, path)
    except OSError as err:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        raise output_failed(path, err) from None
    except BaseException:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        raise


def readable_mode() -> int:
    """0666 under the process umask (what ``open`` would give), not mkstemp's 0600."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def json_safe(obj):
    """``obj`` with every non-finite number as None (JSON's null): strict JSON has no NaN or
    Infinity, and a reader in another language refuses them. Where a figure has no value the
    document says why beside it (a note, a reason)."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    return obj


def write_json_atomic(path: Path, obj) -> None:
    """``obj`` as strict JSON (:func:`json_safe`), written atomically."""
    text = json.dumps(json_safe(obj), indent=2, sort_keys=False, allow_nan=False) + "\n"
    write_atomic(path, lambda tmp: tmp.write_text(text))
