"""Generate a dataset split as a set of chunks, resumably and in parallel
(docs/guide/skills.md#data-generation).

Layout of a dataset directory::

    DIR/<skill>/<split>/chunk-00000.safetensors   one shard per chunk (written atomically)
    DIR/<skill>/<split>/manifest.json             counts, success rate, failures, seeds, simulator, version

A run first keeps every shard already on disk that belongs to the same dataset (same skill, split,
chunk size, seed, sampler and simulator); it then generates the missing chunks as tasks of an
executor (local worker processes or a Ray cluster: each task writes its own shard), and finally
writes the manifest from the shards. A killed run loses at most the chunks in flight; rerunning the
same command finishes the job.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from t2m_core.atomic_files import write_json_atomic
from t2m_core.data.chunks import ChunkSpec, ChunkStats, DataGenerationError, ProposalSource, generate_chunk
from t2m_core.data.records import (
    FAILURE_VOCABULARY,
    SHARD_FORMAT,
    ShardError,
    Transitions,
    read_shard,
    read_shard_header,
    write_shard,
)
from t2m_core.executors import Executor, LocalExecutor, TaskCounts

MANIFEST_NAME = "manifest.json"
TIMINGS_NAME = "timings.jsonl"
"""Per-chunk wall and reset seconds and the executor that ran it, one JSON line each: the cost of the
data, kept out of the shards so that a chunk's shard is byte-identical wherever it ran."""
DEFAULT_CHUNK_SIZE = 250
"""Transitions per chunk: small enough that a killed run loses little, large enough to amortise a
worker's start (seconds of simulation each)."""


@dataclass(frozen=True)
class DatasetJob:
    """One split of one skill to generate.

    Attributes:
        out: the dataset directory (``DIR`` above).
        skill, split: what to generate.
        size: transitions in the split (the last chunk may be smaller).
        chunk_size: transitions per chunk.
        base_seed: the dataset's seed.
        sampler: action sampler of simulated splits.
        actions_per_scene: actions executed from each reset scene (see :class:`ChunkSpec`).
        simulator: simulator plugin name; ``simulator_options`` its options.
        proposal: the skill library of the ``proposal`` sampler (see :class:`ChunkSpec`).
        scenes: where simulated transitions start (see :class:`ChunkSpec`).
        skeleton: the skill sequence task rollouts walk instead of the reference (see :class:`ChunkSpec`).
    """

    out: Path
    skill: str
    split: str
    size: int
    chunk_size: int = DEFAULT_CHUNK_SIZE
    base_seed: int = 0
    sampler: str = "screened"
    simulator: str = "mujoco"
    simulator_options: dict[str, Any] = field(default_factory=dict)
    actions_per_scene: int = 1
    proposal: ProposalSource | None = None
    scenes: str = "data"
    skeleton: str | None = None

    @property
    def directory(self) -> Path:
        """``out/<skill>/<split>``."""
        return Path(self.out) / self.skill / self.split

    def chunks(self) -> list[ChunkSpec]:
        """The split's chunks in order."""
        count = math.ceil(self.size / self.chunk_size)
        return [
            ChunkSpec(
                self.skill,
                self.split,
                index,
                min(self.chunk_size, self.size - index * self.chunk_size),
                self.base_seed,
                self.sampler,
                self.actions_per_scene,
                self.proposal if self.split != "invalid" else None,
                self.scenes if self.split != "invalid" else "data",
                self.skeleton if self.split != "invalid" else None,
            )
            for index in range(count)
        ]

    def settings(self) -> dict[str, Any]:
        """The generation settings that make the split one dataset, as its manifest records them
        (sampler, actions per scene and simulator are those of simulated splits; the invalid
        split's sampler is uniform)."""
        simulated = self.split != "invalid"
        settings = {
            "base_seed": self.base_seed,
            "chunk_size": self.chunk_size,
            "sampler": self.sampler if simulated else "uniform",
            "actions_per_scene": self.actions_per_scene if simulated else None,
            "simulator": {"name": self.simulator, "options": self.simulator_options} if simulated else None,
            "scenes": self.scenes if simulated else "data",
        }
        if simulated and self.proposal is not None:
            settings["proposal"] = self.proposal.identity()
        if simulated and self.skeleton is not None:
            settings["skeleton"] = self.skeleton
        if simulated and self.sampler == "planned":
            from t2m_core.data.rollouts import rollout_planner_identity

            settings["planner"] = rollout_planner_identity()
        return settings

    def shard_header(self, spec: ChunkSpec) -> dict[str, Any]:
        """What a shard of this job records about how it was made."""
        header = spec.header()
        if spec.simulated:
            header["simulator"] = {"name": self.simulator, "options": self.simulator_options}
        return header


@dataclass
class Progress:
    """Running totals reported to a progress callback after every finished chunk, and the chunk
    tasks running, failed and retried (:class:`~t2m_core.executors.TaskCounts`)."""

    chunks_done: int = 0
    chunks_total: int = 0
    transitions: int = 0
    successes: int = 0
    new_transitions: int = 0
    seconds: float = 0.0
    running: int = 0
    failed: int = 0
    retried: int = 0


def generate_dataset(
    job: DatasetJob,
    *,
    workers: int = 1,
    executor: Executor | None = None,
    on_progress: Callable[[Progress], None] | None = None,
) -> dict[str, Any]:
    """Generate the missing chunks of ``job`` and write its manifest; returns the manifest.

    Args:
        job: the split to generate.
        workers: local worker processes (1: in this process), when no ``executor`` is given.
        executor: where the chunk tasks run (:mod:`t2m_core.executors`); its workers must see
            ``job.out``.
        on_progress: called when a chunk finishes or the tasks' counts change (and once at the start).

    Raises:
        DataGenerationError: a chunk cannot be generated (the chunks finished before are kept).
    """
    job = replace(job, out=Path(job.out).resolve())  # a worker's working directory is not the driver's
    _require_same_dataset(job)
    executor = executor or LocalExecutor(workers)
    specs = job.chunks()
    progress = Progress(chunks_total=len(specs))
    pending = []
    for spec in specs:
        header = _existing_header(job, spec)
        if header is None:
            pending.append(spec)
        else:
            progress.chunks_done += 1
            progress.transitions += header["count"]
            progress.successes += header["successes"]
    if on_progress:
        on_progress(progress)

    def on_status(counts: TaskCounts) -> None:
        progress.running, progress.failed, progress.retried = counts.running, counts.failed, counts.retried
        if on_progress:
            on_progress(progress)

    if pending:
        job.directory.mkdir(parents=True, exist_ok=True)
        executor.require_shared(job.directory)
    for spec, (header, stats) in executor.map(functools.partial(make_chunk, job), pending, on_status=on_status):
        _append_timing(job, spec, stats, executor.name)
        progress.chunks_done += 1
        progress.transitions += header["count"]
        progress.new_transitions += header["count"]
        progress.successes += header["successes"]
        progress.seconds += stats.seconds
        if on_progress:
            on_progress(progress)
    return write_manifest(job, executor.describe())


def _require_same_dataset(job: DatasetJob) -> None:
    """Refuse to write into a split whose manifest records other generation settings: its shards would
    all be regenerated, losing the data already there.

    Raises:
        DataGenerationError: naming each differing setting.
    """
    path = job.directory / MANIFEST_NAME
    if not path.exists():
        return
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except ValueError:
        return  # the manifest is rewritten from the shards at the end
    wanted = {"skeleton": None, **job.settings()}
    recorded = {key: manifest[key] for key in wanted if key in manifest}
    recorded.setdefault("skeleton", None)  # reference skeletons, or no rollouts
    if job.split != "invalid":
        recorded.setdefault("actions_per_scene", 1)  # manifests older than the setting: one action per scene
    recorded.setdefault("scenes", "data")  # manifests older than task rollouts
    differing = [f"{key} {recorded[key]!r} (asked: {wanted[key]!r})" for key in wanted if key in recorded and recorded[key] != wanted[key]]
    if differing:
        raise DataGenerationError(
            f"{job.directory} holds a dataset made with other settings: " + ", ".join(differing),
            "rerun with the dataset's settings to extend it, or write the new one to another --out",
        )


def _existing_header(job: DatasetJob, spec: ChunkSpec) -> dict[str, Any] | None:
    """The header of the chunk's shard if it is on disk and belongs to this job, else ``None``
    (a torn, foreign or stale shard is regenerated)."""
    path = job.directory / spec.filename
    if not path.exists():
        return None
    try:
        header = read_shard_header(path)
    except ShardError:
        return None
    expected = job.shard_header(spec)
    if any(header.get(key) != value for key, value in expected.items()) or header.get("count") != spec.size:
        return None
    if header.get("scenes", "data") != spec.scenes or header.get("skeleton") != spec.skeleton:
        return None
    return header


def make_chunk(job: DatasetJob, spec: ChunkSpec) -> tuple[dict[str, Any], ChunkStats]:
    """The task of one chunk, run by a worker: generate it and write its shard (atomically); returns
    the shard's header and what the chunk cost."""
    transitions, stats = _chunk_in_worker(job, spec)
    header = {**job.shard_header(spec), "count": len(transitions), "successes": int(transitions.success.sum()), "stats": stats.as_dict()}
    write_shard(job.directory / spec.filename, transitions, header)
    return header, stats


_WORKER_SIMULATORS: dict[tuple[str, str], Any] = {}


def _chunk_in_worker(job: DatasetJob, spec: ChunkSpec) -> tuple[Transitions, ChunkStats]:
    """Generate one chunk; a worker keeps one simulator per (name, options) between chunks (a reset
    clears its physics, so the chunk does not depend on what ran before)."""
    simulator = None
    if spec.simulated:
        key = (job.simulator, repr(sorted(job.simulator_options.items())))
        simulator = _WORKER_SIMULATORS.get(key)
        if simulator is None:
            from t2m_core.registry import get_registry

            simulator = _WORKER_SIMULATORS[key] = get_registry().create("simulator", job.simulator, job.simulator_options)
    return generate_chunk(spec, simulator)


# --------------------------------------------------------------------------------------------------
# Manifest and loading
# --------------------------------------------------------------------------------------------------


def write_manifest(job: DatasetJob, executor: dict[str, Any] | None = None) -> dict[str, Any]:
    """Summarise the job's shards into ``manifest.json`` (atomically) and return it.

    Args:
        job: the split.
        executor: the executor of this run (``{"name": ..., "workers": ...}``), recorded as is.
    """
    from t2m_core import __version__

    shards, failures = [], Counter()
    count = successes = discarded = draws = 0
    for spec in job.chunks():
        path = job.directory / spec.filename
        header = _existing_header(job, spec)
        if header is None:
            raise ShardError(f"chunk {spec.index} of {job.directory} is missing or stale", "rerun the same `t2m datagen` command")
        shards.append({"file": spec.filename, "count": header["count"], "sha256": _sha256(path)})
        count += header["count"]
        successes += header["successes"]
        stats = header["stats"]
        failures.update(stats["failures"])
        discarded += stats["discarded_failures"]
        draws += stats["draws"]
    manifest = {
        "format": SHARD_FORMAT,
        "t2m_version": __version__,
        "skill": job.skill,
        "split": job.split,
        "count": count,
        "successes": successes,
        "success_rate": round(successes / count, 4) if count else 0.0,
        "failures_seen": dict(sorted(failures.items())),
        "discarded_failures": discarded,
        "draws": draws,
        **job.settings(),
        "failure_vocabulary": list(FAILURE_VOCABULARY),
        **_timing_summary(job),
        "executor": executor,
        "shards": shards,
    }
    write_json_atomic(job.directory / MANIFEST_NAME, manifest)
    return manifest


def _append_timing(job: DatasetJob, spec: ChunkSpec, stats: ChunkStats, executor: str) -> None:
    record = {"chunk": spec.index, "count": spec.size, "seconds": round(stats.seconds, 3), "reset_seconds": round(stats.reset_seconds, 3),
              "executor": executor}
    with open(job.directory / TIMINGS_NAME, "a", encoding="utf-8") as handle:
        handle.write(json.dumps(record) + "\n")


def _timing_summary(job: DatasetJob) -> dict[str, Any]:
    """Seconds per chunk (the latest run of each) summed: what the data cost, per worker-second; and
    how many chunks each executor made."""
    path = job.directory / TIMINGS_NAME
    latest: dict[int, dict[str, Any]] = {}
    if path.exists():
        for line in path.read_text(encoding="utf-8").splitlines():
            try:
                record = json.loads(line)
                latest[int(record["chunk"])] = record
            except (ValueError, KeyError, TypeError):
                continue  # a line torn by a kill
    seconds = sum(r["seconds"] for r in latest.values())
    count = sum(r["count"] for r in latest.values())
    return {
        "worker_seconds": round(seconds, 1),
        "reset_seconds": round(sum(r["reset_seconds"] for r in latest.values()), 1),
        "transitions_per_worker_second": round(count / seconds, 3) if seconds else None,
        "chunks_by_executor": dict(sorted(Counter(r.get("executor", "local") for r in latest.values()).items())),
    }


def manifest_digest(directory: Path | str) -> str:
    """sha256 of a split's ``manifest.json`` (checkpoints record which data trained them)."""
    return _sha256(Path(directory) / MANIFEST_NAME)


def load_split(directory: Path | str) -> Transitions:
    """Every transition of a split directory (``DIR/<skill>/<split>``), in chunk order.

    Raises:
        ShardError: no manifest, or a shard that is missing or does not match its recorded digest.
    """
    directory = Path(directory)
    manifest_path = directory / MANIFEST_NAME
    if not manifest_path.exists():
        raise ShardError(f"no {MANIFEST_NAME} in {directory}", "generate the split with `t2m datagen` (it writes the manifest last)")
    manifest = json.loads(manifest_path.read_text())
    parts = []
    for shard in manifest["shards"]:
        path = directory / shard["file"]
        if not path.exists() or _sha256(path) != shard["sha256"]:
            raise ShardError(f"shard {path} is missing or differs from {manifest_path}", "rerun the `t2m datagen` command that made it")
        parts.append(read_shard(path)[0])
    return Transitions.concatenate(parts)


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def default_workers() -> int:
    """One worker per available core."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
