"""`t2m train` and `t2m calibrate` end to end on a small scripted dataset: the commands train a
learning-curve prefix, record it, and calibrate what planning would do with invalid pairs."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest
from t2m_skills_tableenv.checkpoints import load_q
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.data import generate
from t2m_core.data.generate import DatasetJob, generate_dataset
from tests.core.plugin_doubles import ScriptedSimulator

runner = CliRunner()


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """Pick transitions that succeed exactly when the action's first component is positive."""
    root = tmp_path_factory.mktemp("data")
    patch = pytest.MonkeyPatch()
    patch.setattr(generate, "_WORKER_SIMULATORS", {("scripted", "[]"): ScriptedSimulator(lambda action: action[0] > 0.0)})
    try:
        for split, size, seed in (("train", 400, 1), ("validation", 200, 2), ("invalid", 200, 3)):
            generate_dataset(DatasetJob(root, "pick", split, size, 100, base_seed=seed, sampler="uniform", simulator="scripted"))
    finally:
        patch.undo()
    return root


def test_train_on_a_prefix_then_calibrate(dataset, tmp_path) -> None:
    out = tmp_path / "checkpoints"
    trained = runner.invoke(
        app,
        ["train", "--skill", "pick", "--data", str(dataset), "--out", str(out), "--steps", "300", "--eval-every", "100",
         "--train-size", "200", "--selection-episodes", "4", "--json"],
    )
    assert trained.exit_code == 0, trained.output
    config = json.loads((out / "pick" / "config.json").read_text())
    assert {m["training"]["train_size"] for m in config["models"].values()} == {200}
    # what trained the models: the prefix, not the split's current size
    assert {(m["data"]["train_transitions"], m["data"]["validation_transitions"]) for m in config["models"].values()} == {(200, 200)}
    # the policy was selected in MuJoCo evaluation scenes
    policy_curve = [json.loads(line) for line in (out / "pick" / "metrics-policy.jsonl").read_text().splitlines()]
    assert len(policy_curve) == 3 and all(0.0 <= r["simulated_success"] <= 1.0 for r in policy_curve)
    assert config["models"]["policy"]["training"]["selection_episodes"] == 4
    assert config["models"]["q"]["training"]["ensemble_batches"] == "shared"
    curve = [json.loads(line) for line in (out / "pick" / "metrics-q.jsonl").read_text().splitlines()]
    assert [r["step"] for r in curve] == [100, 200, 300]

    calibrated = runner.invoke(app, ["calibrate", "--skill", "pick", "--data", str(dataset), "--out", str(out), "--json"])
    assert calibrated.exit_code == 0, calibrated.output
    ood = json.loads((out / "pick" / "config.json").read_text())["ood"]
    assert ood["invalid_pairs"] == 200 and ood["in_distribution_pairs"] == 200
    populated = [b for b in ood["bins"]["in_distribution"] if b["count"] >= 20]
    assert populated and all(b["flagged"] <= 0.01 + 1e-9 for b in populated)  # the 1 % rule, per populated bin
    # the pessimistic Q is at most the mean: every invalid pair with mean Q < 0.5 is rejected
    assert ood["invalid_rejected_rate"] >= 1.0 - ood["invalid_share_with_q_high"] - 1e-9
    assert ood["invalid_rejected_rate"] >= ood["detection_rate"] - 1e-9


def test_a_prefix_longer_than_the_split_is_a_clear_error(dataset, tmp_path) -> None:
    result = runner.invoke(
        app, ["train", "--skill", "pick", "--model", "q", "--data", str(dataset), "--out", str(tmp_path), "--steps", "10", "--train-size", "401"]
    )
    assert result.exit_code != 0
    assert "t2m datagen --size 401" in result.output


def test_threads_limit_the_trainings_torch_threads(dataset, tmp_path, monkeypatch) -> None:
    import torch

    before = torch.get_num_threads()
    for name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        monkeypatch.delenv(name, raising=False)  # restored after the test
    try:
        trained = runner.invoke(
            app, ["train", "--skill", "pick", "--model", "q", "--data", str(dataset), "--out", str(tmp_path), "--steps", "10", "--eval-every", "10",
                  "--threads", "1", "--json"],
        )
        assert trained.exit_code == 0, trained.output
        assert json.loads(trained.stdout)["pick"]["q"]["threads"] == 1
        assert torch.get_num_threads() == 1
        assert os.environ["OMP_NUM_THREADS"] == "1"  # what a library loaded later reads
    finally:
        torch.set_num_threads(before)
    refused = runner.invoke(app, ["train", "--skill", "pick", "--data", str(dataset), "--out", str(tmp_path), "--threads", "0"])
    assert refused.exit_code == 2 and "--threads" in refused.output


def test_an_unknown_ensemble_batching_is_refused(dataset, tmp_path) -> None:
    result = runner.invoke(
        app, ["train", "--skill", "pick", "--model", "q", "--data", str(dataset), "--out", str(tmp_path), "--ensemble-batches", "bagging"]
    )
    assert result.exit_code != 0 and "ensemble_batches" in result.output and "'shared' or 'bootstrap'" in result.output


def test_more_train_appends_another_datasets_train_split(dataset, tmp_path, monkeypatch) -> None:
    other = tmp_path / "other"
    monkeypatch.setattr(generate, "_WORKER_SIMULATORS", {("scripted", "[]"): ScriptedSimulator(lambda action: action[0] > 0.0)})
    generate_dataset(DatasetJob(other, "pick", "train", 100, 100, base_seed=9, sampler="uniform", simulator="scripted", actions_per_scene=2))
    out = tmp_path / "checkpoints"
    trained = runner.invoke(
        app,
        ["train", "--skill", "pick", "--model", "q", "--data", str(dataset), "--more-train", str(other), "--out", str(out),
         "--steps", "20", "--eval-every", "10"],
    )
    assert trained.exit_code == 0, trained.output
    data = json.loads((out / "pick" / "config.json").read_text())["models"]["q"]["data"]
    assert data["train_transitions"] == 400 + 100 and data["validation_transitions"] == 200
    assert data["more_train"] == [generate.manifest_digest(other / "pick" / "train")]
    missing = runner.invoke(
        app, ["train", "--skill", "pick", "--model", "q", "--data", str(dataset), "--more-train", str(tmp_path / "nowhere"), "--out", str(out), "--steps", "20"]
    )
    assert missing.exit_code != 0 and "manifest.json" in missing.output


def test_init_from_starts_training_from_another_checkpoints_weights(dataset, tmp_path) -> None:
    from safetensors.numpy import load_file

    from t2m_core.data.proposals import checkpoint_digest

    base = tmp_path / "base"
    common = ["--skill", "pick", "--model", "q", "--data", str(dataset), "--steps", "1", "--eval-every", "1"]
    assert runner.invoke(app, ["train", *common, "--out", str(base)]).exit_code == 0
    # one step at a learning rate that moves nothing measurable: the weights are the start's
    tuned, fresh = tmp_path / "tuned", tmp_path / "fresh"
    result = runner.invoke(app, ["train", *common, "--init-from", str(base), "--learning-rate", "1e-12", "--out", str(tuned)])
    assert result.exit_code == 0, result.output
    assert runner.invoke(app, ["train", *common, "--learning-rate", "1e-12", "--out", str(fresh)]).exit_code == 0
    start, after = load_file(base / "pick" / "q_ensemble.safetensors"), load_file(tuned / "pick" / "q_ensemble.safetensors")
    unstarted = load_file(fresh / "pick" / "q_ensemble.safetensors")
    assert start.keys() == after.keys()
    assert all(np.allclose(start[k], after[k], atol=1e-8) for k in start)
    # without --init-from the same schedule ends elsewhere: one Adam step of 3e-4 separates them
    assert any(np.abs(start[k] - unstarted[k]).max() > 1e-4 for k in start)
    config = json.loads((tuned / "pick" / "config.json").read_text())["models"]["q"]
    assert config["data"]["init_from"] == checkpoint_digest(base, "pick")
    assert config["training"]["learning_rate"] == 1e-12
    missing = runner.invoke(app, ["train", *common, "--init-from", str(tmp_path / "nowhere"), "--out", str(tmp_path / "x")])
    assert missing.exit_code != 0 and "no pick checkpoint" in missing.output


def test_anchor_data_are_recorded_and_need_a_starting_ensemble(dataset, tmp_path) -> None:
    from t2m_core.data.generate import manifest_digest

    base, tuned = tmp_path / "base", tmp_path / "tuned"
    common = ["--skill", "pick", "--model", "q", "--data", str(dataset), "--steps", "2", "--eval-every", "1"]
    assert runner.invoke(app, ["train", *common, "--out", str(base)]).exit_code == 0
    refused = runner.invoke(app, ["train", *common, "--anchor", str(dataset), "--out", str(tmp_path / "x")])
    assert refused.exit_code != 0 and "--init-from" in refused.output
    # the dataset's own train split as the anchor leaves no labelled data: a clear error, nothing trained
    empty = runner.invoke(app, ["train", *common, "--init-from", str(base), "--anchor", str(dataset), "--out", str(tmp_path / "y")])
    assert empty.exit_code != 0 and "nothing is left to learn" in empty.output and not (tmp_path / "y").exists()
    result = runner.invoke(app, ["train", *common, "--init-from", str(base), "--more-train", str(dataset), "--anchor", str(dataset),
                                 "--anchor-weight", "2.5", "--out", str(tuned)])
    assert result.exit_code != 0 and "nothing is left to learn" in result.output  # the same directory twice is still one anchor
    other = tmp_path / "other"
    shutil.copytree(dataset / "pick" / "train", other / "pick" / "train")
    result = runner.invoke(app, ["train", *common, "--init-from", str(base), "--anchor", str(other), "--anchor-weight", "2.5", "--out", str(tuned)])
    assert result.exit_code == 0, result.output
    q = json.loads((tuned / "pick" / "config.json").read_text())["models"]["q"]
    assert q["data"]["anchor"] == [manifest_digest(other / "pick" / "train")] and q["training"]["anchor_weight"] == 2.5
    curve = [json.loads(line) for line in (tuned / "pick" / "metrics-q.jsonl").read_text().splitlines()]
    assert len(curve) == 2 and all("train_anchor_loss" in record for record in curve)


def test_a_relational_ensemble_is_trained_loaded_and_fine_tuned_only_as_one(dataset, tmp_path) -> None:
    from t2m_skills_tableenv.checkpoints import load_q
    from t2m_skills_tableenv.networks import RelationalQEnsemble

    base = tmp_path / "base"
    common = ["--skill", "pick", "--model", "q", "--data", str(dataset), "--steps", "2", "--eval-every", "1"]
    result = runner.invoke(app, ["train", *common, "--q-network", "relational", "--out", str(base)])
    assert result.exit_code == 0, result.output
    architecture = json.loads((base / "pick" / "config.json").read_text())["models"]["q"]["architecture"]
    assert architecture["type"] == "RelationalQEnsemble" and architecture["context_rows"] == 2  # end effector + the picked object
    assert isinstance(load_q(base / "pick"), RelationalQEnsemble)
    mixed = runner.invoke(app, ["train", *common, "--init-from", str(base), "--out", str(tmp_path / "mixed")])
    assert mixed.exit_code != 0
    assert "holds a relational Q-ensemble and the settings train a mlp one" in mixed.output and "--q-network relational" in mixed.output and "--anchor" in mixed.output
    assert not (tmp_path / "mixed" / "pick" / "q_ensemble.safetensors").exists()
    tuned = runner.invoke(app, ["train", *common, "--q-network", "relational", "--init-from", str(base), "--out", str(tmp_path / "tuned")])
    assert tuned.exit_code == 0, tuned.output
    # with anchors, another network is distilled from the starting one: a fresh MLP learns its predictions
    other = tmp_path / "other"
    shutil.copytree(dataset / "pick" / "train", other / "pick" / "train")
    distilled = runner.invoke(app, ["train", *common, "--init-from", str(base), "--anchor", str(other), "--out", str(tmp_path / "mlp")])
    assert distilled.exit_code == 0, distilled.output
    q = json.loads((tmp_path / "mlp" / "pick" / "config.json").read_text())["models"]["q"]
    assert q["architecture"]["type"] == "QEnsemble" and q["data"]["distilled"] is True
    assert "distilled" not in json.loads((tmp_path / "tuned" / "pick" / "config.json").read_text())["models"]["q"]["data"]
    unknown = runner.invoke(app, ["train", *common, "--q-network", "transformer", "--out", str(tmp_path / "x")])
    assert unknown.exit_code != 0 and "q_network" in unknown.output


def test_a_policy_trained_towards_searched_targets_records_them_and_a_bad_ranking_is_refused(dataset, tmp_path) -> None:
    base = tmp_path / "base"
    common = ["--skill", "pick", "--data", str(dataset), "--steps", "20", "--eval-every", "10", "--selection-episodes", "0"]
    assert runner.invoke(app, ["train", *common, "--model", "q", "--out", str(base)]).exit_code == 0
    searched = ["--model", "policy", "--policy-targets", "8", "--policy-target-value", "mean", "--policy-target-weight", "2",
                "--policy-target-focus", "0.25", "--policy-target-tolerance", "0.05", "--json"]
    result = runner.invoke(app, ["train", *common, *searched, "--out", str(base)])
    assert result.exit_code == 0, result.output
    outcome = json.loads(result.stdout[result.stdout.index("{"):])["pick"]["policy"]
    assert outcome["target_search_seconds"] >= 0 and "train_target_distance" in (base / "pick" / "metrics-policy.jsonl").read_text()
    training = json.loads((base / "pick" / "config.json").read_text())["models"]["policy"]["training"]
    assert (training["policy_targets"], training["policy_target_value"], training["policy_target_weight"]) == (8, "mean", 2.0)
    assert (training["policy_target_focus"], training["policy_target_tolerance"]) == (0.25, 0.05)
    whole = runner.invoke(app, ["train", *common, "--model", "policy", "--policy-targets", "8", "--policy-target-focus", "1", "--out", str(tmp_path / "y")])
    assert whole.exit_code == 2 and "--policy-target-focus" in whole.output and not (tmp_path / "y").exists()  # a batch of moved states alone
    bad = runner.invoke(app, ["train", *common, "--model", "policy", "--policy-targets", "8", "--policy-target-value", "median", "--out", str(base)])
    assert bad.exit_code == 2 and "policy_target_value" in bad.output and "'min' or 'mean'" in bad.output


def test_task_scenes_without_the_proposal_sampler_are_a_clear_error(tmp_path) -> None:
    result = runner.invoke(app, ["datagen", "--skill", "place", "--split", "train", "--size", "4", "--scenes", "tasks", "--out", str(tmp_path)])
    assert result.exit_code != 0
    assert "--sampler proposal" in result.output
    unknown = runner.invoke(app, ["datagen", "--skill", "place", "--split", "train", "--size", "4", "--scenes", "kitchen", "--out", str(tmp_path)])
    assert unknown.exit_code != 0 and "data, tasks" in unknown.output
    assert not any(tmp_path.iterdir())  # nothing written


def test_a_bad_rollout_skeleton_is_refused_before_any_work(tmp_path) -> None:
    base = ["datagen", "--skill", "pull", "--split", "train", "--size", "4", "--sampler", "proposal", "--out", str(tmp_path / "out")]
    cases = {
        "pick(hook), pull(green_box, hook)": ("tasks:task3", "green_box"),
        "pick(hook)": ("tasks:task3", "never calls pull"),
        "pick(hook), pull(blue_box, hook)": ("tasks", "--scenes tasks:ID"),
    }
    for skeleton, (scenes, problem) in cases.items():
        result = runner.invoke(app, [*base, "--scenes", scenes, "--skeleton", skeleton])
        assert result.exit_code == 2, result.output
        assert problem in result.output and "Traceback" not in result.output
        assert "transitions/s" not in result.output  # refused before the progress bar, not by the first chunk
    assert not list((tmp_path / "out").rglob("*.safetensors"))


def scripted_pull_data(data):
    """Train (200) and validation (100) Pull splits in ``data`` from a scripted simulator in which
    an action succeeds where its second component is positive."""
    patch = pytest.MonkeyPatch()
    patch.setattr(generate, "_WORKER_SIMULATORS", {("scripted", "[]"): ScriptedSimulator(lambda action: action[1] > 0.0)})
    try:
        for split, size, seed in (("train", 200, 1), ("validation", 100, 2)):
            generate_dataset(DatasetJob(data, "pull", split, size, 100, base_seed=seed, sampler="uniform", simulator="scripted"))
    finally:
        patch.undo()
    return data


def test_a_geometric_ensemble_trains_on_the_screen_predictions_chosen(tmp_path) -> None:
    """``--screen`` picks the predictions the network reads (a flag and a margin here, not Pull's
    default two margins): the trained checkpoint is that network; names the primitive does not predict, or a
    network that reads no screen, are refused before any training."""
    data = scripted_pull_data(tmp_path / "data")
    common = ["train", "--skill", "pull", "--model", "q", "--data", str(data), "--steps", "20", "--eval-every", "10"]
    trained = runner.invoke(app, [*common, "--q-network", "geometric", "--screen", "in_the_way, reach_margin", "--out", str(tmp_path / "out")])
    assert trained.exit_code == 0, trained.output
    q = json.loads((tmp_path / "out" / "pull" / "config.json").read_text())["models"]["q"]
    assert q["architecture"]["screen"] == ["in_the_way", "reach_margin"] and q["architecture"]["input"] == 102
    assert q["training"]["screen"] == ["in_the_way", "reach_margin"]
    assert load_q(tmp_path / "out" / "pull").features == ("in_the_way", "reach_margin")
    unknown = runner.invoke(app, [*common, "--q-network", "geometric", "--screen", "in_the_way,tipped", "--out", str(tmp_path / "x")])
    assert unknown.exit_code == 2 and "asked for tipped" in unknown.output and "clearance, sweep_gap, reach_margin" in unknown.output  # the names it predicts
    unread = runner.invoke(app, [*common, "--screen", "clearance", "--out", str(tmp_path / "x")])
    assert unread.exit_code == 2 and "--q-network geometric" in unread.output
    assert not (tmp_path / "x").exists()


def test_a_geometric_policy_trains_and_an_unknown_policy_network_is_refused(tmp_path) -> None:
    """``--policy-network geometric``: the checkpoint records the probes' network and its weights
    load into it; an unknown name is refused before any training."""
    from t2m_skills_tableenv.checkpoints import load_weights
    from t2m_skills_tableenv.geometric_policy import GeometricGaussianPolicy, build_policy

    data = scripted_pull_data(tmp_path / "data")
    common = ["train", "--skill", "pull", "--data", str(data), "--steps", "20", "--eval-every", "10", "--selection-episodes", "0"]
    assert runner.invoke(app, [*common, "--model", "q", "--out", str(tmp_path / "out")]).exit_code == 0
    trained = runner.invoke(app, [*common, "--model", "policy", "--policy-network", "geometric", "--out", str(tmp_path / "out")])
    assert trained.exit_code == 0, trained.output
    policy = json.loads((tmp_path / "out" / "pull" / "config.json").read_text())["models"]["policy"]
    assert policy["architecture"]["type"] == "GeometricGaussianPolicy" and policy["architecture"]["input"] == 105
    assert policy["training"]["policy_network"] == "geometric"
    network = load_weights(tmp_path / "out" / "pull" / "policy.safetensors", build_policy(policy["architecture"]))
    assert isinstance(network, GeometricGaussianPolicy) and network.skill == "pull"
    unknown = runner.invoke(app, [*common, "--model", "policy", "--policy-network", "transformer", "--out", str(tmp_path / "x")])
    assert unknown.exit_code == 2 and "policy_network" in unknown.output and "Traceback" not in unknown.output
    assert not (tmp_path / "x").exists()
