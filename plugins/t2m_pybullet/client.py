"""Headless PyBullet clients, connected without PyBullet's console noise on stdout.

``pybullet_utils.BulletClient`` connects with an ``options`` string, and PyBullet's C code then prints
``argv[0]=`` to file descriptor 1, where ``--json`` output goes. A connection is made with that
descriptor pointed at ``/dev/null``. (PyBullet's build date goes to stderr, with the logs.)
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator

_C_LIBRARY = ctypes.CDLL(None)


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    sys.stdout.flush()
    saved, devnull = os.dup(1), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        _C_LIBRARY.fflush(None)  # C's stdout buffer, written while it still points at /dev/null
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def connect():
    """A new DIRECT (headless) ``BulletClient``; each one is an independent physics server."""
    with _quiet_stdout():
        import pybullet
        from pybullet_utils import bullet_client

        return bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
