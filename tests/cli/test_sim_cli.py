"""``t2m sim demo`` reports a missed goal with a non-zero exit status (scripted simulator, no physics)."""

from __future__ import annotations

import json
from types import SimpleNamespace

from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SimulatorSpec
from tests.core.plugin_doubles import ScriptedSimulator

runner = CliRunner()


def test_demo_exits_nonzero_when_the_goal_is_not_reached(t2m_registry, t2m_plugin, tmp_path):
    def register():
        return [SimulatorSpec(name="failing", factory=lambda _options: ScriptedSimulator(success=False), summary="test double")]

    t2m_plugin(SimpleNamespace(t2m_register_simulators=hookimpl(register)), name="failing")
    out = tmp_path / "demo"
    result = runner.invoke(app, ["sim", "demo", "--task", "task0", "--sim", "failing", "--out", str(out)])
    assert result.exit_code == 1, result.output
    written = json.loads((out / "result.json").read_text(encoding="utf-8"))
    assert not written["success"] and written["failure"].startswith("no parameters found for pick(")
    assert written["failure_counts"] == {"collision": written["executions"]}
