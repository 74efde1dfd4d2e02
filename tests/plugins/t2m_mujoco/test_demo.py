from typer.testing import CliRunner

from t2m_core.cli.main import app


def test_cli_lists_demo():
    result = CliRunner().invoke(app, ["sim", "demo", "--help"])
    assert result.exit_code == 0 and "--task" in result.output and "--out" in result.output
