"""Assembling an embedded model from its chunk packages: hash-verified, atomic, verified once; a
missing optional model names its extra; any model file has a digest."""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.metadata

import pytest

from t2m_core.errors import ModelFileError
from t2m_llm_local import model_files
from t2m_llm_local.catalogue import DEFAULT_MODEL, EMBEDDED_MODELS, QWEN_15B


@pytest.fixture
def small_chunks(tmp_path, monkeypatch):
    """Three small chunk files standing in for the default model's packages; returns the expected bytes."""
    parts = [b"GGUF" + bytes(range(200)), bytes(300), b"tail"]
    paths = []
    for index, data in enumerate(parts):
        path = tmp_path / f"part{index}.bin"
        path.write_bytes(data)
        paths.append(path)
    whole = b"".join(parts)
    small = dataclasses.replace(EMBEDDED_MODELS[DEFAULT_MODEL], size=len(whole), sha256=hashlib.sha256(whole).hexdigest())
    monkeypatch.setitem(EMBEDDED_MODELS, DEFAULT_MODEL, small)
    monkeypatch.setattr(model_files, "chunk_files", lambda model: paths)
    monkeypatch.setenv("T2M_CACHE_DIR", str(tmp_path / "cache"))
    return whole


def test_assembles_once_into_the_cache_and_then_only_checks_the_marker(small_chunks, monkeypatch):
    path = model_files.default_model_path()
    assert path.parent == model_files.models_dir() and path.read_bytes() == small_chunks
    assert path.with_name(path.name + ".verified").is_file()
    assert [p.name for p in path.parent.iterdir() if p.name.endswith(".part")] == []

    def no_hashing(_path):
        raise AssertionError("a verified file must not be hashed again")

    monkeypatch.setattr(model_files, "sha256_of", no_hashing)
    assert model_files.embedded_model_path(DEFAULT_MODEL) == path
    assert model_files.model_digest(path) == hashlib.sha256(small_chunks).hexdigest()  # from the marker


def test_a_modified_cached_file_is_rebuilt(small_chunks):
    path = model_files.default_model_path()
    path.write_bytes(b"corrupt" + small_chunks[7:])  # same size, new mtime, wrong hash
    assert model_files.default_model_path().read_bytes() == small_chunks


def test_chunks_that_do_not_match_are_refused_and_leave_nothing(small_chunks, monkeypatch):
    monkeypatch.setitem(EMBEDDED_MODELS, DEFAULT_MODEL, dataclasses.replace(EMBEDDED_MODELS[DEFAULT_MODEL], sha256="0" * 64))
    with pytest.raises(ModelFileError, match="does not match") as raised:
        model_files.default_model_path()
    assert "pip install --force-reinstall" in str(raised.value)
    assert list(model_files.models_dir().iterdir()) == []


def test_a_missing_chunk_package_names_the_install_command(monkeypatch, tmp_path):
    monkeypatch.setenv("T2M_CACHE_DIR", str(tmp_path))
    absent = dataclasses.replace(QWEN_15B, chunk_distributions=("t2m-no-such-chunk-package",))
    monkeypatch.setitem(EMBEDDED_MODELS, QWEN_15B.name, absent)
    with pytest.raises(ModelFileError, match="is not installed") as raised:
        model_files.embedded_model_path(QWEN_15B.name)
    assert "pip install t2m-no-such-chunk-package==0.2.0" in raised.value.hint
    optional = dataclasses.replace(absent, extra="some-extra")  # a model shipped as an extra names it
    monkeypatch.setitem(EMBEDDED_MODELS, QWEN_15B.name, optional)
    with pytest.raises(ModelFileError) as raised:
        model_files.embedded_model_path(QWEN_15B.name)
    assert "pip install 'text2motion[some-extra]'" in raised.value.hint
    with pytest.raises(ModelFileError, match="no embedded model named"):
        model_files.embedded_model_path("gpt-2")


def test_any_model_file_gets_a_digest_hashed_once(tmp_path, monkeypatch):
    monkeypatch.setenv("T2M_CACHE_DIR", str(tmp_path / "cache"))
    weights = tmp_path / "mine.gguf"
    weights.write_bytes(b"weights")
    assert model_files.model_digest(weights) == hashlib.sha256(b"weights").hexdigest()
    monkeypatch.setattr(model_files, "sha256_of", lambda _path: pytest.fail("hashed twice"))
    assert model_files.model_digest(weights) == hashlib.sha256(b"weights").hexdigest()


def _installed(model) -> bool:
    try:
        importlib.metadata.distribution(model.chunk_distributions[0])
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


@pytest.mark.parametrize("model", list(EMBEDDED_MODELS.values()), ids=list(EMBEDDED_MODELS))
def test_the_real_chunk_packages_are_found_in_order(model):
    if model.extra is not None and not _installed(model):
        pytest.skip(f"the optional {model.name} chunks are not installed (text2motion[{model.extra}])")
    chunks = model_files.chunk_files(model)
    assert [chunk.name for chunk in chunks] == [f"part{index:02d}.bin" for index in range(1, len(model.chunk_distributions) + 1)]
    assert sum(chunk.stat().st_size for chunk in chunks) == model.size
