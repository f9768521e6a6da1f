"""MuJoCo's passive callback is global process state: the one place that installs it.

:func:`passive_callback` installs a callback only around a simulation (models are compiled
before, never while it is installed), refuses to replace a callback somebody else installed,
and restores the previous one afterwards. The rig (rig/simulate.py, rig/chain.py) and the
native session (rig/native_callback.py) both go through it.
"""

from __future__ import annotations

import contextlib
import threading
from typing import Callable, Iterator

import mujoco

__all__ = ["passive_callback"]

_lock = threading.Lock()


@contextlib.contextmanager
def passive_callback(callback: Callable) -> Iterator[None]:
    """Install ``callback`` as MuJoCo's global passive callback for the duration of the block.

    Raises:
      RuntimeError: another passive callback is already installed (another rig, in this
        thread or another, or foreign code): sharing it would silently mix two models' forces.
    """
    if not _lock.acquire(blocking=False):
        raise RuntimeError("another jointrig simulation holds MuJoCo's passive callback; "
                           "run rigs one after another (or use separate processes)")
    try:
        previous = mujoco.get_mjcb_passive()
        if previous is not None:
            raise RuntimeError(f"a MuJoCo passive callback is already installed ({previous!r}); "
                               f"jointrig will not replace or share it")
        mujoco.set_mjcb_passive(callback)
        try:
            yield
        finally:
            mujoco.set_mjcb_passive(previous)
    finally:
        _lock.release()
