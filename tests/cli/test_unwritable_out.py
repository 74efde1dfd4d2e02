"""Every command that writes into ``--out`` refuses an unwritable directory before any work, with one
line of error naming it (no traceback)."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from t2m_core.cli.main import app

runner = CliRunner()

COMMANDS = {
    "eval": ["eval", "--planners", "hybrid", "--tasks", "task0", "--seeds", "0"],
    "sim demo": ["sim", "demo", "--task", "task0", "--seed", "0"],
    "datagen": ["datagen", "--skill", "pick", "--split", "invalid", "--size", "5"],
}


@pytest.mark.parametrize("name", COMMANDS)
def test_an_unwritable_out_is_one_line_of_error(name: str, tmp_path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    result = runner.invoke(app, [*COMMANDS[name], "--out", str(blocker / "out")])
    assert result.exit_code == 2, result.output
    assert "cannot write to" in result.output and "Traceback" not in result.output
    assert blocker.read_text() == ""
