"""Assembling the embedded model from its chunk packages: hash-verified, atomic, verified once."""

from __future__ import annotations

import hashlib

import pytest

from t2m_core.errors import ModelFileError
from t2m_llm_local import model_files


@pytest.fixture
def small_chunks(tmp_path, monkeypatch):
    """Three small chunk files standing in for the six packages; returns the expected bytes."""
    parts = [b"GGUF" + bytes(range(200)), bytes(300), b"tail"]
    paths = []
    for index, data in enumerate(parts):
        path = tmp_path / f"part{index}.bin"
        path.write_bytes(data)
        paths.append(path)
    whole = b"".join(parts)
    monkeypatch.setattr(model_files, "chunk_files", lambda: paths)
    monkeypatch.setattr(model_files, "DEFAULT_MODEL_SIZE", len(whole))
    monkeypatch.setattr(model_files, "DEFAULT_MODEL_SHA256", hashlib.sha256(whole).hexdigest())
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
    assert model_files.default_model_path() == path


def test_a_modified_cached_file_is_rebuilt(small_chunks):
    path = model_files.default_model_path()
    path.write_bytes(b"corrupt" + small_chunks[7:])  # same size, new mtime, wrong hash
    assert model_files.default_model_path().read_bytes() == small_chunks


def test_chunks_that_do_not_match_are_refused_and_leave_nothing(small_chunks, monkeypatch):
    monkeypatch.setattr(model_files, "DEFAULT_MODEL_SHA256", "0" * 64)
    with pytest.raises(ModelFileError, match="does not match") as raised:
        model_files.default_model_path()
    assert "pip install --force-reinstall" in str(raised.value)
    assert list(model_files.models_dir().iterdir()) == []


def test_the_real_chunk_packages_are_found_in_order():
    chunks = model_files.chunk_files()
    assert [chunk.name for chunk in chunks] == [f"part0{index}.bin" for index in range(1, 7)]
    assert sum(chunk.stat().st_size for chunk in chunks) == 491_400_064
