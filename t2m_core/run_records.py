"""Reading run directories back (docs/guide/run-records.md): what ``t2m show`` prints."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from t2m_core.errors import T2MError


def read_result(directory: Path) -> dict[str, Any] | None:
    """``result.json`` of a run directory, or ``None`` when the episode never wrote it (killed hard).

    Raises:
        T2MError: the file exists but is not a JSON object.
    """
    path = Path(directory) / "result.json"
    if not path.exists():
        return None
    try:
        result = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise T2MError(f"cannot read {path}: {error}", "the run was written by another tool, or the file is damaged") from None
    if not isinstance(result, dict):
        raise T2MError(f"{path} does not hold a run result (a JSON object)", "pass a run directory written by `t2m run` or `t2m eval`")
    return result


def read_plan_tree(directory: Path) -> list[dict[str, Any]]:
    """The records of ``plan_tree.jsonl`` in order ([] when the file is absent).

    Raises:
        T2MError: naming the file and line of a record that is not a JSON object with an ``event``.
    """
    path = Path(directory) / "plan_tree.jsonl"
    if not path.exists():
        return []
    records = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except ValueError:
            record = None
        if not isinstance(record, dict) or "event" not in record:
            raise T2MError(f"{path}, line {number}, is not a plan-tree record", "the file is damaged; rerun the episode")
        records.append(record)
    return records


def episode_results(evaluation: Path) -> list[tuple[Path, dict[str, Any]]]:
    """Every episode of an evaluation directory (``<planner>/<task>/seed<N>``) that wrote its ``result.json``
    (finished, interrupted or stopped by an error), sorted by path."""
    found = []
    for path in sorted(Path(evaluation).glob("*/*/seed*/result.json")):
        result = read_result(path.parent)
        if result is not None:
            found.append((path.parent, result))
    return found
