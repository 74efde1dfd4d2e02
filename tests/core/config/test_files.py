"""Writing a resolved configuration: YAML that resolves back to the same configuration, written atomically."""

from __future__ import annotations

from pathlib import Path

import pytest

from t2m_core.config import RunConfig, resolve_config, write_config
from t2m_core.config import files as config_files


def test_written_config_resolves_back_to_itself(tmp_path: Path) -> None:
    config = resolve_config(flags={"task": "task4", "seed": 7, "planner": "hybrid"}, overrides=["output.video=false"])
    path = tmp_path / "run" / "config.yaml"
    write_config(config, path)
    assert resolve_config([path]) == config
    assert path.read_text(encoding="utf-8").startswith("task: task4\nseed: 7\n")  # keys in model order


def test_a_failed_write_keeps_the_previous_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "config.yaml"
    write_config(RunConfig(seed=1), path)

    def crash(config: RunConfig) -> str:
        raise OSError("disk full")

    monkeypatch.setattr(config_files, "config_to_yaml", crash)
    with pytest.raises(OSError, match="disk full"):
        write_config(RunConfig(seed=2), path)
    assert resolve_config([path]).seed == 1
    assert [entry.name for entry in tmp_path.iterdir()] == ["config.yaml"]  # no temporary file left
