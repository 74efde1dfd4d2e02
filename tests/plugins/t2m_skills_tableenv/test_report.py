"""The skill report's summaries, on hand-made predictions whose answers are counted by hand."""

from __future__ import annotations

import json

import numpy as np
import pytest

from t2m_skills_tableenv.report import errors_by_outcome, markdown_table, reliability


def test_errors_by_outcome_counts_what_the_pessimistic_prediction_gets_wrong() -> None:
    q_min = np.array([0.9, 0.2, 0.7, 0.8, 0.6, 0.1, 0.4])
    failures = [None, None, "disturbed", "disturbed", "disturbed", "collision", None]
    rows = errors_by_outcome(q_min, failures)
    assert list(rows) == ["disturbed", "success", "collision"]  # most frequent first, ties by name
    assert rows["disturbed"] == {"count": 3, "mean_q_min": pytest.approx(0.7), "wrong": 1.0}  # all called successes
    assert rows["success"] == {"count": 3, "mean_q_min": pytest.approx(0.5), "wrong": pytest.approx(2 / 3)}  # 0.2, 0.4 missed
    assert rows["collision"] == {"count": 1, "mean_q_min": pytest.approx(0.1), "wrong": 0.0}


def test_errors_by_outcome_at_exactly_one_half_is_a_failure_prediction() -> None:
    rows = errors_by_outcome(np.array([0.5, 0.5]), [None, "unreachable"])
    assert rows["success"]["wrong"] == 1.0 and rows["unreachable"]["wrong"] == 0.0


def test_reliability_bins_hold_their_predictions_and_realised_rates() -> None:
    rows = reliability(np.array([0.05, 0.07, 0.95]), np.array([False, True, True]))
    assert [(row["bin_low"], row["count"]) for row in rows] == [(0.0, 2), (0.9, 1)]
    assert rows[0]["predicted"] == pytest.approx(0.06) and rows[0]["realised"] == 0.5


def test_the_markdown_report_lists_outcomes_under_the_skill_table() -> None:
    report = {
        "pick": {
            "dataset": {"train": 10, "validation": 4, "invalid": 2},
            "q": {"precision": 0.5, "recall": 1.0, "accuracy": 0.75},
            "q_by_outcome": errors_by_outcome(np.array([0.9, 0.8, 0.1, 0.3]), [None, "disturbed", "collision", "collision"]),
        }
    }
    text = markdown_table(report)
    assert "| pick | 10 / 4 / 2 | 50.0% | 100.0% | 75.0% |" in text
    assert "| pick | collision | 2 | 0.20 | 0.0% |" in text
    assert "| pick | disturbed | 1 | 0.80 | 100.0% |" in text


def test_the_report_reads_the_ood_figures_of_the_separate_detectors(tmp_path) -> None:
    from typer.testing import CliRunner

    from t2m_core.cli.main import app
    from t2m_skills_tableenv.checkpoints import update_config
    from tests.plugins.t2m_skills_tableenv.test_skill_checkpoints import write_checkpoint

    for library, threshold in (("own", 0.05), ("detectors", 0.2)):
        for name in ("pick", "place", "pull", "push"):
            write_checkpoint(tmp_path / library / name, threshold=threshold)
            update_config(tmp_path / library / name, skill=name, ood={"threshold": threshold, "detection_rate": 4 * threshold})
    runner = CliRunner()
    plain = runner.invoke(app, ["skills", "report", "--episodes", "0", "--checkpoints", str(tmp_path / "own"), "--out", str(tmp_path / "a"), "--json"])
    detected = runner.invoke(app, ["skills", "report", "--episodes", "0", "--checkpoints", str(tmp_path / "own"), "--ood-detectors",
                                   str(tmp_path / "detectors"), "--out", str(tmp_path / "b"), "--json"])
    assert plain.exit_code == 0 and detected.exit_code == 0, detected.output
    assert "| 20.0% |" in (tmp_path / "a" / "report.md").read_text() and "| 80.0% |" in (tmp_path / "b" / "report.md").read_text()
    report = json.loads((tmp_path / "b" / "report.json").read_text())
    assert report["push"]["ood"]["threshold"] == 0.2 and report["push"]["ood"]["detector"] == str(tmp_path / "detectors" / "push")
    both = runner.invoke(app, ["skills", "report", "--episodes", "0", "--checkpoints", str(tmp_path / "own"), "--published-ood",
                               "--ood-detectors", str(tmp_path / "detectors"), "--out", str(tmp_path / "c")])
    assert both.exit_code != 0 and "exclude each other" in both.output and not (tmp_path / "c").exists()
