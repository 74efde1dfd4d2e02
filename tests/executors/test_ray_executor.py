"""The Ray executor for real: a Ray head on this machine with two worker processes runs a small
datagen and a small eval, one worker is killed mid-task, and what is on disk equals what the local
executor writes (docs/guide/scaling.md#fault-tolerance).

The commands run as a user runs them, ``t2m ... --executor ray --address ADDR`` in their own
process; the components are the doubles of :mod:`tests.executors.cluster_doubles`, which the Ray
workers load by name because the driver forwards ``T2M_PLUGINS`` to them.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import ray  # noqa: F401 - pinned in the test extra: a missing Ray fails here, the test never skips
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.data.generate import DatasetJob, generate_dataset
from t2m_core.evaluation import grid
from t2m_core.registry import Registry, set_registry
from tests.executors.cluster_doubles import KILL_MARKER, MODULE, SELECTION

pytestmark = pytest.mark.slow
ROOT = Path(__file__).parents[2]


@dataclass
class Cluster:
    address: str
    kill_marker: Path
    driver_environment: dict[str, str]

    def t2m(self, *arguments: str) -> subprocess.CompletedProcess:
        """Run ``t2m ARGUMENTS --executor ray --address ADDR`` as a driver of this cluster."""
        command = [sys.executable, "-m", "t2m_core.cli.main", *arguments, "--executor", "ray", "--address", self.address]
        done = subprocess.run(command, check=False, cwd=ROOT, env=self.driver_environment, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr[-3000:]
        return done


@pytest.fixture(scope="module")
def cluster(tmp_path_factory) -> Iterator[Cluster]:
    """``ray start --head`` with 2 CPUs (two worker processes), token authentication with a token of
    its own; stopped (SIGTERM: the head stops every process it started) at teardown."""
    temporary = Path(tempfile.mkdtemp(prefix="t2m-ray-", dir="/tmp"))  # short: Ray's socket paths must fit 107 bytes
    kill_marker = tmp_path_factory.mktemp("kill") / "kill-one-worker"
    authentication = {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(32), "RAY_USAGE_STATS_ENABLED": "0"}
    base = {name: value for name, value in os.environ.items() if name != "T2M_PLUGINS"}
    # the workers import the doubles from the checkout; T2M_PLUGINS is not set here: the driver forwards it
    head_environment = {**base, **authentication, "PYTHONPATH": str(ROOT), KILL_MARKER: str(kill_marker)}
    command = [sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--block", "--port", "0",
               "--node-ip-address", "127.0.0.1", "--num-cpus", "2", "--include-dashboard", "false", "--disable-usage-stats",
               "--dashboard-agent-listen-port", "0", "--temp-dir", str(temporary)]
    log = open(temporary / "head.log", "w")  # noqa: SIM115 - closed at teardown
    head = subprocess.Popen(command, env=head_environment, stdout=log, stderr=subprocess.STDOUT)
    try:
        address_file = temporary / "ray_current_cluster"
        deadline = time.monotonic() + 90
        while not address_file.exists() or not address_file.read_text().strip():
            assert head.poll() is None and time.monotonic() < deadline, (temporary / "head.log").read_text()[-3000:]
            time.sleep(0.5)
        driver_environment = {**base, **authentication, "PYTHONPATH": str(ROOT), "T2M_PLUGINS": MODULE, "OMP_NUM_THREADS": "1"}
        yield Cluster(address_file.read_text().strip(), kill_marker, driver_environment)
    finally:
        head.terminate()
        try:
            head.wait(timeout=60)
        except subprocess.TimeoutExpired:
            head.kill()
        log.close()
        shutil.rmtree(temporary, ignore_errors=True)


@pytest.fixture
def doubles(monkeypatch) -> Iterator[None]:
    """This process's registry with the doubles, for the local executor's reference runs."""
    monkeypatch.setenv("T2M_PLUGINS", MODULE)
    previous = set_registry(Registry.from_entry_points())
    yield
    set_registry(previous)


def without_timings(record: object) -> object:
    """A run record without its wall-clock seconds (``timings``, ``*_seconds``, the transcript's
    ``elapsed_s``), which vary by run: a test double answers in microseconds, which round to 0.0 on
    idle cores but not always on busy ones."""
    if isinstance(record, dict):
        return {k: without_timings(v) for k, v in record.items() if k not in ("timings", "elapsed_s") and not k.endswith("_seconds")}
    if isinstance(record, list):
        return [without_timings(v) for v in record]
    return record


def lines(path: Path) -> list[object]:
    """A JSON-lines record, without its wall-clock seconds."""
    return [without_timings(json.loads(line)) for line in path.read_text().splitlines()]


def shards(directory: Path) -> dict[str, bytes]:
    return {path.name: path.read_bytes() for path in sorted(directory.glob("chunk-*.safetensors"))}


def test_datagen_on_ray_writes_the_local_shards_even_when_a_worker_dies(cluster, doubles, tmp_path) -> None:
    for split, simulator in (("invalid", "mujoco"), ("train", "mortal")):
        local = generate_dataset(DatasetJob(tmp_path / "local", "pick", split, 12, 4, 3, "uniform", simulator))
        if split == "train":
            cluster.kill_marker.touch()
        cluster.t2m("datagen", "--skill", "pick", "--split", split, "--size", "12", "--chunk-size", "4", "--seed", "3",
                    "--sampler", "uniform", "--sim", simulator, "--out", str(tmp_path / "ray"))
        assert not cluster.kill_marker.exists()  # a worker died mid-chunk, and Ray ran its chunk again
        directory = tmp_path / "ray" / "pick" / split
        assert shards(directory) == shards(tmp_path / "local" / "pick" / split) and len(shards(directory)) == 3
        manifest = json.loads((directory / "manifest.json").read_text())
        assert manifest["executor"] == {"name": "ray", "workers": 2} and manifest["chunks_by_executor"] == {"ray": 3}
        assert [s["sha256"] for s in manifest["shards"]] == [s["sha256"] for s in local["shards"]]
        assert local["executor"] == {"name": "local", "workers": 1}


def test_eval_on_ray_writes_the_local_run_records_even_when_a_worker_dies(cluster, doubles, tmp_path) -> None:
    episodes = grid(["hybrid"], ["task0"], [0, 1])
    local = CliRunner().invoke(app, ["eval", "--planners", "hybrid", "--tasks", "task0", "--seeds", "0-1", *SELECTION,
                                     "--out", str(tmp_path / "local")])
    assert local.exit_code == 0, local.output
    cluster.kill_marker.touch()
    cluster.t2m("eval", "--planners", "hybrid", "--tasks", "task0", "--seeds", "0-1", *SELECTION, "--out", str(tmp_path / "ray"))
    assert not cluster.kill_marker.exists()  # a worker died mid-episode, and Ray ran the episode again
    for episode in episodes:
        ran, reference = episode.directory(tmp_path / "ray"), episode.directory(tmp_path / "local")
        result = json.loads((ran / "result.json").read_text())
        assert result["executed"] and not result["interrupted"]
        assert without_timings(result) == without_timings(json.loads((reference / "result.json").read_text()))
        for record in ("plan_tree.jsonl", "transcript.jsonl"):
            assert lines(ran / record) == lines(reference / record), record
        assert (ran / "config.yaml").read_text() == (reference / "config.yaml").read_text()
    tables = json.loads((tmp_path / "ray" / "results.json").read_text())
    assert tables["executor"] == {"name": "ray", "workers": 2} and tables["rows"][0]["episodes"] == 2
    assert json.loads((tmp_path / "local" / "results.json").read_text())["executor"] == {"name": "local", "workers": 1}
