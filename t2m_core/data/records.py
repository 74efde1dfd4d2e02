"""Skill transitions and their on-disk shards (docs/guide/skills.md#data-generation).

One transition is one execution of a primitive from a reset scene (a one-step bandit: discount 0).
A shard is a safetensors file of column arrays plus a JSON header: any tool reads it with
``safetensors.numpy.load_file`` and ``safe_open(...).metadata()``, without t2m and without pickle.

Columns (``N`` transitions):

============================  =====================  ===================================================
name                          shape, dtype           meaning
============================  =====================  ===================================================
``observation``               ``(N, 8, 12) float32``  raw observation before the primitive
``action``                    ``(N, 4) float32``      normalised action in ``[-1, 1]``
``reward``                    ``(N,) float32``        1 on success, else 0
``next_observation``          ``(N, 8, 12) float32``  raw observation after it (= ``observation`` when not simulated)
``terminated``                ``(N,) bool``           the episode ended normally (= not truncated)
``truncated``                 ``(N,) bool``           a control failure ended the primitive
``failure``                   ``(N,) int16``          index into the header's ``failures`` (-1: success)
``arguments``                 ``(N, 3) int8``         the call's arguments as indices into ``objects`` (-1 pad)
``present``                   ``(N, 7) int8``         the scene's objects in row order (rows 1..7), -1 pad
``row_order``                 ``(N, 8) int8``         argument-first order of the raw rows
``shuffle_range``             ``(N, 2) int8``         start, stop of the rows a trainer may shuffle
``symbolic_state``            ``(N,) int16``          index into ``enumerate_symbolic_states()`` of the scene
``scene_seed``                ``(N,) int64``          the accepted reset seed (the scene is reproducible from it)
============================  =====================  ===================================================
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from t2m_core.atomic_files import write_bytes_atomic
from t2m_core.domain.objects import OBJECTS
from t2m_core.domain.observation import FEATURES, MAX_OBJECTS, OBSERVATION_ROWS
from t2m_core.domain.primitives import FAILURES
from t2m_core.errors import T2MError

SHARD_FORMAT = "t2m-transitions/1"
"""Value of the header's ``format`` key; bumped when a column changes meaning."""
OBJECT_VOCABULARY: tuple[str, ...] = tuple(OBJECTS)
"""Object names by index, as ``arguments`` and ``present`` store them."""
INVALID_GROUNDING = "invalid_grounding"
"""Failure of the invalid split: a symbolically invalid call, not simulated."""
FAILURE_VOCABULARY: tuple[str, ...] = (*FAILURES, INVALID_GROUNDING)
"""Failure reasons by index, as ``failure`` stores them."""
MAX_ARGUMENTS = 3
METADATA_KEY = "t2m"
"""The shard's safetensors metadata key; its value is JSON with ``format``, ``objects``,
``failures`` (the vocabularies) and ``header`` (how the shard was made)."""


class ShardError(T2MError):
    """A shard that is missing, unreadable, of another format or inconsistent with its header."""


@dataclass
class Transitions:
    """A column batch of transitions (see the module docstring for the columns)."""

    observation: np.ndarray
    action: np.ndarray
    reward: np.ndarray
    next_observation: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    failure: np.ndarray
    arguments: np.ndarray
    present: np.ndarray
    row_order: np.ndarray
    shuffle_range: np.ndarray
    symbolic_state: np.ndarray
    scene_seed: np.ndarray

    def __len__(self) -> int:
        return int(self.reward.shape[0])

    @property
    def success(self) -> np.ndarray:
        """``(N,) bool`` reward == 1."""
        return self.reward > 0.5

    def columns(self) -> dict[str, np.ndarray]:
        """Column name -> array."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def take(self, index: np.ndarray | slice) -> Transitions:
        """The rows ``index`` of every column."""
        return Transitions(**{name: column[index] for name, column in self.columns().items()})

    @classmethod
    def concatenate(cls, parts: Sequence[Transitions]) -> Transitions:
        """All rows of ``parts`` in order (at least one part)."""
        if not parts:
            raise ValueError("concatenate needs at least one batch")
        return cls(**{f.name: np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(cls)})

    def failure_names(self) -> list[str | None]:
        """The failure reason of each row (``None`` for successes)."""
        return [None if code < 0 else FAILURE_VOCABULARY[code] for code in self.failure.tolist()]

    def object_names(self, row: int) -> tuple[str, ...]:
        """The present objects of transition ``row`` in observation-row order."""
        return tuple(OBJECT_VOCABULARY[i] for i in self.present[row] if i >= 0)

    def argument_names(self, row: int) -> tuple[str, ...]:
        """The call's arguments of transition ``row``."""
        return tuple(OBJECT_VOCABULARY[i] for i in self.arguments[row] if i >= 0)


COLUMN_SPECS: dict[str, tuple[tuple[int, ...], Any]] = {
    "observation": ((OBSERVATION_ROWS, FEATURES), np.float32),
    "action": ((4,), np.float32),
    "reward": ((), np.float32),
    "next_observation": ((OBSERVATION_ROWS, FEATURES), np.float32),
    "terminated": ((), np.bool_),
    "truncated": ((), np.bool_),
    "failure": ((), np.int16),
    "arguments": ((MAX_ARGUMENTS,), np.int8),
    "present": ((MAX_OBJECTS,), np.int8),
    "row_order": ((OBSERVATION_ROWS,), np.int8),
    "shuffle_range": ((2,), np.int8),
    "symbolic_state": ((), np.int16),
    "scene_seed": ((), np.int64),
}
"""Column -> (per-row shape, dtype)."""


def empty_transitions() -> Transitions:
    """A batch with no rows."""
    return Transitions(**{name: np.zeros((0, *shape), dtype) for name, (shape, dtype) in COLUMN_SPECS.items()})


def name_indices(names: Sequence[str], width: int) -> np.ndarray:
    """``(width,) int8`` indices of ``names`` in :data:`OBJECT_VOCABULARY`, padded with -1."""
    indices = np.full(width, -1, dtype=np.int8)
    indices[: len(names)] = [OBJECT_VOCABULARY.index(n) for n in names]
    return indices


def failure_code(failure: str | None) -> int:
    """The ``failure`` column value of a reason (-1 for success)."""
    return -1 if failure is None else FAILURE_VOCABULARY.index(failure)


# --------------------------------------------------------------------------------------------------
# Shards
# --------------------------------------------------------------------------------------------------


def write_shard(path: Path | str, transitions: Transitions, header: Mapping[str, Any]) -> None:
    """Write ``transitions`` and a JSON-serialisable ``header`` as one safetensors shard, atomically
    (temporary file, then rename: an interrupted write never leaves a partial shard)."""
    from safetensors.numpy import save

    columns = _checked_columns(transitions, str(path))
    # One metadata key: safetensors writes its metadata map in no fixed order, and a chunk's shard
    # must be byte-identical wherever it ran.
    description = {"format": SHARD_FORMAT, "objects": OBJECT_VOCABULARY, "failures": FAILURE_VOCABULARY, "header": dict(header)}
    metadata = {METADATA_KEY: json.dumps(description, sort_keys=True)}
    # safetensors has no bool dtype in every reader: store bool columns as uint8.
    stored = {k: (v.astype(np.uint8) if v.dtype == np.bool_ else np.ascontiguousarray(v)) for k, v in columns.items()}
    write_bytes_atomic(path, save(stored, metadata=metadata))


def read_shard_header(path: Path | str) -> dict[str, Any]:
    """The JSON header of a shard, without reading its arrays.

    Raises:
        ShardError: unreadable file or another format.
    """
    from safetensors import safe_open

    try:
        with safe_open(str(path), framework="numpy") as handle:
            metadata = handle.metadata() or {}
    except Exception as error:  # safetensors raises several types for a torn or foreign file
        raise ShardError(f"cannot read shard {path}: {error}", "delete it; the generator rewrites it") from None
    return _description(metadata, path)["header"]


def read_shard(path: Path | str) -> tuple[Transitions, dict[str, Any]]:
    """``(transitions, header)`` of a shard.

    Raises:
        ShardError: unreadable, another format, or columns that disagree with the schema.
    """
    from safetensors import safe_open

    try:
        with safe_open(str(path), framework="numpy") as handle:
            metadata = handle.metadata() or {}
            arrays = {key: handle.get_tensor(key) for key in handle.keys()}  # noqa: SIM118 (no __iter__)
    except Exception as error:
        raise ShardError(f"cannot read shard {path}: {error}", "delete it; the generator rewrites it") from None
    description = _description(metadata, path)
    if tuple(description["objects"]) != OBJECT_VOCABULARY or tuple(description["failures"]) != FAILURE_VOCABULARY:
        raise ShardError(f"shard {path} was written with another object or failure vocabulary", "regenerate it")
    missing = set(COLUMN_SPECS) - set(arrays)
    if missing:
        raise ShardError(f"shard {path} lacks column(s) {', '.join(sorted(missing))}", "regenerate it")
    columns = {name: arrays[name].astype(dtype, copy=False) for name, (_, dtype) in COLUMN_SPECS.items()}
    transitions = Transitions(**columns)
    _checked_columns(transitions, str(path))
    return transitions, description["header"]


def _description(metadata: Mapping[str, str], path: Path | str) -> dict[str, Any]:
    try:
        description = json.loads(metadata[METADATA_KEY])
        found = description["format"]
    except (KeyError, TypeError, ValueError):
        found = None
    if found != SHARD_FORMAT:
        raise ShardError(
            f"{path} is not a {SHARD_FORMAT} shard (format {found!r})",
            "point at a dataset written by `t2m datagen`, or regenerate it",
        )
    return description


def _checked_columns(transitions: Transitions, where: str) -> dict[str, np.ndarray]:
    columns = transitions.columns()
    count = len(transitions)
    for name, (shape, dtype) in COLUMN_SPECS.items():
        column = columns[name]
        if column.shape != (count, *shape) or column.dtype != dtype:
            raise ShardError(
                f"{where}: column {name} has shape {column.shape} {column.dtype}, expected {(count, *shape)} "
                f"{np.dtype(dtype)}"
            )
    return columns
