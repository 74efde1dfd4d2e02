"""Datasets of chunks: resuming after a kill, no partial shard, manifests, shard errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from t2m_core.data import generate
from t2m_core.data.generate import DatasetJob, generate_dataset, load_split
from t2m_core.data.records import ShardError, read_shard
from tests.core.plugin_doubles import ScriptedSimulator


def _job(tmp_path, size=12, chunk_size=4) -> DatasetJob:
    return DatasetJob(tmp_path, "pick", "train", size, chunk_size, base_seed=3, sampler="uniform", simulator="scripted")


def _use(monkeypatch, simulator) -> None:
    monkeypatch.setattr(generate, "_WORKER_SIMULATORS", {("scripted", "[]"): simulator})


def test_a_killed_run_leaves_no_partial_shard_and_resumes_to_the_same_dataset(tmp_path, monkeypatch) -> None:
    rule = lambda action: action[0] > 0.0  # noqa: E731
    _use(monkeypatch, ScriptedSimulator(rule))
    reference = generate_dataset(_job(tmp_path / "reference"))

    _use(monkeypatch, ScriptedSimulator(rule, interrupt_after=7))  # dies inside the second chunk
    job = _job(tmp_path / "killed")
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(job)
    files = sorted(p.name for p in job.directory.iterdir())
    assert [f for f in files if f.endswith(".safetensors")] == ["chunk-00000.safetensors"]
    assert not [f for f in files if f.endswith(".tmp")], files
    assert "manifest.json" not in files  # written last, from complete shards only

    _use(monkeypatch, ScriptedSimulator(rule))
    resumed = generate_dataset(job)
    assert [s["sha256"] for s in resumed["shards"]] == [s["sha256"] for s in reference["shards"]]
    assert resumed["count"] == 12 and resumed["successes"] >= 5


def test_the_manifest_summarises_the_shards(tmp_path, monkeypatch) -> None:
    _use(monkeypatch, ScriptedSimulator(lambda action: action[1] > 0.5))
    manifest = generate_dataset(_job(tmp_path))
    transitions = load_split(_job(tmp_path).directory)
    assert manifest["count"] == len(transitions) == 12
    assert manifest["successes"] == int(transitions.success.sum())
    assert manifest["failures_seen"]["collision"] >= 12 - manifest["successes"]
    assert manifest["simulator"] == {"name": "scripted", "options": {}} and manifest["sampler"] == "uniform"
    on_disk = json.loads((_job(tmp_path).directory / "manifest.json").read_text())
    assert on_disk["shards"] == manifest["shards"]


def test_a_stale_or_torn_shard_is_regenerated(tmp_path, monkeypatch) -> None:
    _use(monkeypatch, ScriptedSimulator(lambda action: action[0] > 0.0))
    first = generate_dataset(_job(tmp_path))
    shard = _job(tmp_path).directory / "chunk-00001.safetensors"
    shard.write_bytes(shard.read_bytes()[:100])  # torn
    with pytest.raises(ShardError, match="chunk-00001"):
        read_shard(shard)
    with pytest.raises(ShardError, match="differs from"):
        load_split(_job(tmp_path).directory)
    again = generate_dataset(_job(tmp_path))
    assert again["shards"] == first["shards"]


def test_a_shard_round_trips_and_reads_without_t2m(tmp_path, monkeypatch) -> None:
    from safetensors import safe_open
    from safetensors.numpy import load_file

    _use(monkeypatch, ScriptedSimulator(lambda action: True))
    generate_dataset(_job(tmp_path, size=4))
    path = _job(tmp_path).directory / "chunk-00000.safetensors"
    transitions, header = read_shard(path)
    raw = load_file(str(path))
    np.testing.assert_array_equal(raw["observation"], transitions.observation)
    with safe_open(str(path), framework="numpy") as handle:
        description = json.loads(handle.metadata()["t2m"])
    assert description["format"] == "t2m-transitions/1" and description["header"] == header
    assert header["skill"] == "pick" and header["count"] == 4


def test_a_split_made_with_other_settings_is_refused_and_kept(tmp_path, monkeypatch) -> None:
    from dataclasses import replace

    from t2m_core.data.chunks import DataGenerationError

    _use(monkeypatch, ScriptedSimulator(lambda action: action[0] > 0.0))
    first = generate_dataset(_job(tmp_path))
    assert first["actions_per_scene"] == 1
    for other, named in ((replace(_job(tmp_path), actions_per_scene=4), "actions_per_scene 1"), (replace(_job(tmp_path), sampler="heuristic"), "sampler 'uniform'")):
        with pytest.raises(DataGenerationError, match=named):
            generate_dataset(other)
    assert generate_dataset(replace(_job(tmp_path), size=16))["shards"][:3] == first["shards"]  # extending is fine
    elsewhere = generate_dataset(replace(_job(tmp_path / "k4"), actions_per_scene=4))
    assert elsewhere["actions_per_scene"] == 4 and elsewhere["count"] == 12
