"""``t2m list-plugins`` and ``t2m --version``, in-process and as the installed console script."""

from __future__ import annotations

import json
import subprocess
import sys

from typer.testing import CliRunner

from t2m_core import __version__
from t2m_core.cli.main import app
from t2m_core.testing import HEAVY_MODULES
from tests.core.plugin_doubles import EveryKind, plugin, toy_simulator_spec

runner = CliRunner()

ROW_KEYS = {"kind", "name", "aliases", "provider", "version", "status"}


def test_version() -> None:
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.stdout == f"t2m {__version__}\n"


def test_json_rows_describe_every_component(t2m_registry, t2m_plugin) -> None:
    t2m_plugin(EveryKind(), name="every-kind", provider="acme-t2m", version="1.4")
    result = runner.invoke(app, ["list-plugins", "--json"])
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [(row["kind"], row["name"]) for row in rows] == [
        ("simulator", "toysim"),
        ("skill_library", "toy-skills"),
        ("feasibility_planner", "toy-cem"),
        ("language_model", "toy-llm"),
        ("scene_parser", "toy-parser"),
        ("task_planner", "toy-hybrid"),
    ]
    llm = rows[3]
    assert ROW_KEYS <= set(llm)
    assert (llm["aliases"], llm["provider"], llm["version"], llm["status"]) == (["gpt-toy"], "acme-t2m", "1.4", "ok")


def test_broken_plugin_is_listed_as_failed_with_exit_status_0(t2m_fake_distribution) -> None:
    t2m_fake_distribution(
        "broken-t2m", version="0.1", entry_points={"broken": "broken_t2m"}, files={"broken_t2m.py": "1 / 0\n"}
    )
    result = runner.invoke(app, ["list-plugins", "--json"])
    assert result.exit_code == 0, result.output
    broken = [row for row in json.loads(result.stdout) if row["name"] == "broken"]
    assert broken == [
        {
            "kind": None,
            "name": "broken",
            "aliases": [],
            "provider": "broken-t2m",
            "version": "0.1",
            "status": "failed: ZeroDivisionError: division by zero",
            "summary": "broken_t2m",
            "plugin": "broken",
            "builtin": False,
        }
    ]
    table = runner.invoke(app, ["list-plugins"])
    assert table.exit_code == 0
    assert "ZeroDivisionError" in table.stdout and "broken-t2m" in table.stdout


def test_duplicate_names_exit_2_naming_both_providers(t2m_registry, t2m_plugin) -> None:
    t2m_plugin(plugin(t2m_register_simulators=[toy_simulator_spec()]), name="one", provider="first-dist")
    t2m_plugin(plugin(t2m_register_simulators=[toy_simulator_spec()]), name="two", provider="second-dist")
    result = runner.invoke(app, ["list-plugins"])
    assert result.exit_code == 2
    assert "Error: simulator name 'toysim' is provided twice" in result.stderr
    assert "first-dist" in result.stderr and "second-dist" in result.stderr
    assert "Hint: uninstall one of the two packages" in result.stderr
    assert "Traceback" not in result.output


def test_installed_console_script_lists_the_builtins_without_heavy_imports() -> None:
    # run the real entry point in a fresh interpreter, then report which heavy modules it imported
    probe = (
        "import json, sys\n"
        "from t2m_core.cli.main import main\n"
        "sys.argv = ['t2m', *sys.argv[1:]]\n"
        "try:\n    main()\nexcept SystemExit as stop:\n    code = stop.code\n"
        f"print(json.dumps([m for m in {list(HEAVY_MODULES)!r} if m in sys.modules]), file=sys.stderr)\n"
    )
    for arguments in (["--help"], ["list-plugins", "--json"]):
        result = subprocess.run(
            [sys.executable, "-c", probe, *arguments], capture_output=True, text=True, timeout=120, check=False
        )
        assert result.returncode == 0, result.stderr
        assert json.loads(result.stderr.strip().splitlines()[-1]) == [], (
            f"t2m {' '.join(arguments)} imported heavy modules"
        )
    rows = json.loads(result.stdout)
    assert all(ROW_KEYS <= set(row) for row in rows)
    truth = next(row for row in rows if row["name"] == "ground-truth")
    assert (truth["kind"], truth["provider"], truth["status"], truth["aliases"]) == (
        "scene_parser",
        "text2motion",
        "ok",
        ["truth"],
    )
