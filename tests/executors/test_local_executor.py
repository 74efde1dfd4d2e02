"""The executor interface on the local pool: results, a worker killed mid-task, a failing task, and
the choice of executor (docs/guide/scaling.md)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.errors import T2MError
from t2m_core.executors import LocalExecutor, TaskCounts, make_executor
from t2m_core.executors.local import worker_threads

ROOT = Path(__file__).parents[2]


def square(item: int) -> int:
    return item * item


def square_dying_once(item: tuple[int, str]) -> int:
    """Kills its worker process on item 3 while ``marker`` exists (deleting it first: one death)."""
    value, marker = item
    if value == 3:
        try:
            os.unlink(marker)
        except FileNotFoundError:
            pass
        else:
            os.kill(os.getpid(), signal.SIGKILL)
    return value * value


def torch_threads(item: int) -> tuple[int, str | None]:
    import torch

    return torch.get_num_threads(), os.environ.get("OMP_NUM_THREADS")


def fail_on_two(item: int) -> int:
    if item == 2:
        raise ValueError("no square for two")
    return item


@pytest.mark.parametrize("workers", [1, 2])
def test_every_item_comes_back_with_its_result(workers: int) -> None:
    seen: list[TaskCounts] = []
    with LocalExecutor(workers) as executor:
        results = dict(executor.map(square, list(range(6)), on_status=lambda counts: seen.append(TaskCounts(**vars(counts)))))
    assert results == {i: i * i for i in range(6)}
    assert seen[-1] == TaskCounts(total=6, done=6, running=0)
    assert max(counts.running for counts in seen) == workers


def test_pool_workers_share_the_cores_among_their_math_threads() -> None:
    assert [worker_threads(w, cores=8) for w in (1, 2, 3, 8, 16)] == [8, 4, 2, 1, 1]
    import torch  # loaded in the parent: forked workers inherit its thread count unless told

    results = dict(LocalExecutor(2).map(torch_threads, [0, 1, 2, 3]))
    expected = worker_threads(2)
    assert set(results.values()) == {(expected, str(expected))}


def test_a_task_whose_worker_dies_runs_again_and_the_others_are_kept(tmp_path) -> None:
    marker = tmp_path / "kill"
    marker.touch()
    seen: list[TaskCounts] = []
    items = [(value, str(marker)) for value in range(6)]
    results = dict(LocalExecutor(2).map(square_dying_once, items, on_status=lambda counts: seen.append(TaskCounts(**vars(counts)))))
    assert not marker.exists()  # a worker did die
    assert {value: result for (value, _), result in results.items()} == {i: i * i for i in range(6)}
    assert seen[-1].retried >= 1 and seen[-1].failed == 0 and seen[-1].done == 6


@pytest.mark.parametrize("workers", [1, 2])
def test_after_a_failure_nothing_new_starts_and_the_error_names_its_task(workers: int) -> None:
    finished, finished_when_it_failed = [], []

    def on_status(counts: TaskCounts) -> None:
        if counts.failed and not finished_when_it_failed:
            finished_when_it_failed.append(len(finished))

    with pytest.raises(ValueError, match="no square for two") as raised:
        for item, _ in LocalExecutor(workers).map(fail_on_two, list(range(20)), on_status=on_status):
            finished.append(item)
    assert 2 not in finished
    assert len(finished) - finished_when_it_failed[0] < 2 * workers  # only the tasks already in flight finish
    notes = "\n".join(raised.value.__notes__)
    assert "while running 2" in notes and "rerun the same command" in notes


def test_the_executor_names_are_checked() -> None:
    with pytest.raises(T2MError, match="use one of: local, ray"):
        make_executor("dask", workers=1)
    with pytest.raises(T2MError, match="add --executor ray"):
        make_executor("local", workers=1, address="auto")


def test_without_ray_the_ray_executor_names_the_extra_in_one_line(monkeypatch, tmp_path) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # as if not installed
    monkeypatch.delitem(sys.modules, "t2m_core.executors.ray_executor", raising=False)
    result = CliRunner().invoke(app, ["datagen", "--skill", "pick", "--split", "invalid", "--size", "4", "--out", str(tmp_path),
                                      "--executor", "ray"])
    assert result.exit_code == 2
    assert result.output.strip() == 'Error: Ray is not installed: --executor ray needs the ray extra, pip install "text2motion[ray]"'


def test_the_local_executor_does_not_import_ray(tmp_path) -> None:
    script = (
        "import sys\n"
        "from typer.testing import CliRunner\n"
        "from t2m_core.cli.main import app\n"
        f"result = CliRunner().invoke(app, ['datagen', '--skill', 'pick', '--split', 'invalid', '--size', '4', '--out', {str(tmp_path)!r}])\n"
        "assert result.exit_code == 0, result.output\n"
        "assert 'ray' not in sys.modules\n"
    )
    done = subprocess.run([sys.executable, "-c", script], check=False, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
