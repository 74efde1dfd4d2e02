"""Write files so that a reader never sees a partial one: write a temporary file in the destination's
directory, then ``os.replace`` it over the destination (atomic on POSIX). An interrupted job leaves the
previous good file in place."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any


def write_text_atomic(path: Path | str, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically, creating parent directories; mode 0644."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_json_atomic(path: Path | str, content: Any) -> None:
    """Write ``content`` as indented JSON to ``path`` atomically. Unserialisable content raises
    before anything is written."""
    write_text_atomic(path, json.dumps(content, indent=2) + "\n")


def write_bytes_atomic(path: Path | str, content: bytes) -> None:
    """Write ``content`` to ``path`` atomically, creating parent directories; mode 0644."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(descriptor, "wb") as handle:
            handle.write(content)
        os.chmod(temporary, 0o644)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def ensure_writable_directory(directory: Path | str) -> Path:
    """Create ``directory`` (with parents) and check that a file can be written there.

    Raises:
        T2MError: naming the directory and why, so a command fails before any work.
    """
    from t2m_core.errors import T2MError

    directory = Path(directory)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=directory, prefix=".t2m-write-test-"):
            pass  # a unique name: two commands checking the same directory at once do not collide
    except OSError as error:
        raise T2MError(f"cannot write to {directory}: {error.strerror}", "choose a writable directory with --out") from None
    return directory
