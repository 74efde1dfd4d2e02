"""Training the skill models: losses fall, classes separate, runs resume, rows shuffle only where
they may (docs/guide/skills.md#q-ensemble)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from t2m_core.errors import T2MError
from t2m_skills_tableenv.dataset import SkillTensors, shuffle_rows
from t2m_skills_tableenv.networks import QEnsemble
from t2m_skills_tableenv.training import Anchor, DynamicsStage, PolicyStage, QStage, StageSettings, WeightAverage, q_metrics, run_stage


def synthetic(count: int, seed: int) -> SkillTensors:
    """Success exactly when the action's first component exceeds the state's first feature: a
    problem whose answer the test knows."""
    generator = torch.Generator().manual_seed(seed)
    rows = torch.rand(count, 8, 12, generator=generator) - 0.5
    actions = torch.rand(count, 4, generator=generator) * 2 - 1
    rewards = (actions[:, 0] > rows[:, 0, 0] * 2).float()
    next_rows = rows.clone()
    next_rows[:, 1, :3] += 0.1 * actions[:, None, :3].squeeze(1)  # the moved object follows the action
    ranges = torch.tensor([[2, 5]]).expand(count, 2)
    return SkillTensors(rows, next_rows, ranges, actions, rewards)


def test_the_q_ensemble_learns_a_separable_problem(tmp_path) -> None:
    train, validation = synthetic(2048, 0), synthetic(512, 1)
    settings = StageSettings(steps=600, batch_size=128, learning_rate=3e-3, eval_every=200)
    stage = QStage(train, validation, settings)
    before = q_metrics(stage.network, validation)
    result = run_stage(stage, settings, tmp_path)
    after = result["best"]
    assert after["loss"] < 0.6 * before["loss"]
    assert after["accuracy"] > 0.85 and after["precision"] > 0.8 and after["recall"] > 0.8
    curve = [json.loads(line) for line in (tmp_path / "metrics-q.jsonl").read_text().splitlines()]
    assert [r["step"] for r in curve] == [200, 400, 600]


def test_bootstrapped_members_each_train_on_their_own_resample(tmp_path) -> None:
    train, validation = synthetic(2048, 0), synthetic(512, 1)
    settings = StageSettings(steps=600, batch_size=128, learning_rate=3e-3, eval_every=600, ensemble_batches="bootstrap")
    stage = QStage(train, validation, settings)
    assert stage.resample is not None and stage.resample.shape == (8, 2048)
    unique = [len(torch.unique(member)) / 2048 for member in stage.resample]
    assert all(0.58 < share < 0.68 for share in unique)  # sampling with replacement keeps ~1 - 1/e
    assert len({tuple(member[:20].tolist()) for member in stage.resample}) == 8
    # the same seed draws the same resamples: a resumed run trains on the data it started with
    assert torch.equal(QStage(train, validation, settings).resample, stage.resample)
    result = run_stage(stage, settings, tmp_path)
    assert result["best"]["accuracy"] > 0.85


def test_per_member_inputs_reach_only_their_member() -> None:
    q = QEnsemble()
    states, actions = torch.randn(8, 5, 96), torch.randn(8, 5, 4)
    per_member = q(states, actions)
    assert per_member.shape == (5, 8)
    for member in (0, 5):
        torch.testing.assert_close(per_member[:, member], q(states[member], actions[member])[:, member])


def test_the_first_n_training_samples_are_a_prefix_and_too_many_is_a_clear_error() -> None:
    data = synthetic(100, 0)
    head = data.head(40)
    assert len(head) == 40 and torch.equal(head.rows, data.rows[:40]) and torch.equal(head.rewards, data.rewards[:40])
    assert data.head(None) is data
    with pytest.raises(T2MError, match="t2m datagen --size 101"):
        data.head(101)


def test_the_ensemble_members_are_one_batched_module_with_independent_weights() -> None:
    q = QEnsemble()
    states, actions = torch.randn(5, 96), torch.randn(5, 4)
    logits = q(states, actions)
    assert logits.shape == (5, 8)
    assert logits.std(dim=1).min() > 0  # different initialisations give different members
    member = 3  # the batched module equals member 3 evaluated on its own
    x = torch.cat((states, actions), dim=1)
    for layer, (weight, bias) in enumerate(zip(q.weights, q.biases)):
        x = x @ weight[member] + bias[member]
        x = torch.relu(x) if layer < len(q.weights) - 1 else x
    torch.testing.assert_close(x.squeeze(1), logits[:, member])


def test_the_policy_climbs_the_frozen_q_ensemble(tmp_path) -> None:
    train, validation = synthetic(2048, 0), synthetic(512, 1)
    q_settings = StageSettings(steps=600, batch_size=128, learning_rate=3e-3, eval_every=600)
    q_stage = QStage(train, validation, q_settings)
    run_stage(q_stage, q_settings, tmp_path)
    settings = StageSettings(steps=400, batch_size=128, learning_rate=3e-3, eval_every=100)
    stage = PolicyStage(train, validation, q_stage.network, settings)
    start = stage.evaluate().metrics["q_min_mean"]
    result = run_stage(stage, settings, tmp_path)
    assert result["best"]["q_min_mean"] > start + 0.2
    actions = stage.network(validation.states())
    # the learned actions succeed by the rule the data was made with
    assert (actions[:, 0] > validation.rows[:, 0, 0] * 2).float().mean() > 0.8


def test_simulated_success_selects_the_policy_over_the_ensembles_judgement(tmp_path) -> None:
    train, validation = synthetic(2048, 0), synthetic(512, 1)
    q_settings = StageSettings(steps=300, batch_size=128, learning_rate=3e-3, eval_every=300)
    q_stage = QStage(train, validation, q_settings)
    run_stage(q_stage, q_settings, tmp_path)
    rates = iter([0.2, 0.9, 0.5, 0.4])  # a double: the second evaluation's policy succeeds most
    settings = StageSettings(steps=400, batch_size=128, learning_rate=3e-3, eval_every=100, selection_episodes=10)
    stage = PolicyStage(train, validation, q_stage.network, settings, simulate=lambda network: next(rates))
    result = run_stage(stage, settings, tmp_path)
    assert result["best_step"] == 200 and result["best"]["simulated_success"] == 0.9


def test_patience_stops_a_stage_that_no_longer_improves_and_a_rerun_stays_stopped(tmp_path) -> None:
    train, validation = synthetic(2048, 0), synthetic(512, 1)
    q_settings = StageSettings(steps=200, batch_size=128, learning_rate=3e-3, eval_every=200)
    q_stage = QStage(train, validation, q_settings)
    run_stage(q_stage, q_settings, tmp_path)
    rates = iter([0.3, 0.8, 0.5, 0.4, 0.6, 0.9])  # best at the second evaluation, then two worse
    settings = StageSettings(steps=600, batch_size=64, learning_rate=1e-3, eval_every=100, selection_episodes=5, patience=2)
    stage = PolicyStage(train, validation, q_stage.network, settings, simulate=lambda network: next(rates))
    result = run_stage(stage, settings, tmp_path)
    assert result["steps"] == 400 and result["scheduled_steps"] == 600 and result["best_step"] == 200
    assert [json.loads(line)["step"] for line in (tmp_path / "metrics-policy.jsonl").read_text().splitlines()] == [100, 200, 300, 400]
    again = run_stage(PolicyStage(train, validation, q_stage.network, settings, simulate=lambda network: 1.0), settings, tmp_path)
    assert again["steps"] == 400 and again["best_step"] == 200  # resumed: already stopped


def test_policy_success_counts_the_simulated_outcomes() -> None:
    from t2m_skills_tableenv.episodes import policy_success
    from tests.core.plugin_doubles import ScriptedSimulator

    simulator = ScriptedSimulator(lambda action: action[0] > 0.0)
    good = policy_success("pick", lambda states: np.full((len(states), 4), 0.5), simulator, 6)
    bad = policy_success("pick", lambda states: np.full((len(states), 4), -0.5), simulator, 6)
    assert good["success_rate"] == 1.0 and good["outcomes"] == {"success": 6}
    assert bad["success_rate"] == 0.0 and bad["outcomes"] == {"collision": 6}
    assert simulator.executions == 12


def test_dynamics_trains_on_successes_and_lowers_the_error(tmp_path) -> None:
    train, validation = synthetic(2048, 0), synthetic(512, 1)
    settings = StageSettings(steps=300, batch_size=256, learning_rate=1e-3, eval_every=100)
    stage = DynamicsStage(train, validation, settings)
    assert len(stage.train) == int(train.rewards.sum())
    before = -stage.evaluate().score
    result = run_stage(stage, settings, tmp_path)
    assert result["best"]["loss"] < 0.5 * before


class _Killed(Exception):
    pass


def _killed_at_step_20(stage, settings: StageSettings, checkpoint) -> None:
    """Run ``stage`` until its evaluation at step 20, then stop it as a kill would."""

    def kill(step, record):
        if step == 20:
            raise _Killed

    with pytest.raises(_Killed):
        run_stage(stage, settings, checkpoint, on_progress=kill)


def test_a_killed_run_resumes_from_its_last_evaluation(tmp_path) -> None:
    train, validation = synthetic(512, 0), synthetic(128, 1)
    settings = StageSettings(steps=40, batch_size=32, learning_rate=1e-3, eval_every=10)

    def stage() -> QStage:
        torch.manual_seed(settings.seed)  # the same initial weights each time, as train_skill seeds them
        return QStage(train, validation, settings)

    whole = run_stage(stage(), settings, tmp_path / "whole")

    _killed_at_step_20(stage(), settings, tmp_path / "killed")
    resumed = run_stage(stage(), settings, tmp_path / "killed")
    assert resumed["best"] == pytest.approx(whole["best"], rel=1e-5)
    steps = [json.loads(line)["step"] for line in (tmp_path / "killed" / "metrics-q.jsonl").read_text().splitlines()]
    assert steps == [10, 20, 30, 40]


def test_the_weight_average_follows_the_trained_weights_at_its_decay() -> None:
    source = torch.nn.Linear(3, 2)
    start = source.weight.detach().clone()
    average = WeightAverage(source, decay=0.75)
    with torch.no_grad():
        source.weight.fill_(1.0)
    average.update()
    average.update()
    # two steps towards 1: 1 + (w0 - 1) * 0.75²
    assert torch.allclose(average.network.weight, 1.0 + (start - 1.0) * 0.5625)
    assert not average.network.weight.requires_grad
    with pytest.raises(ValueError, match="decay"):
        WeightAverage(source, decay=1.0)


def test_the_weight_average_starts_from_weights_loaded_after_the_stage_was_built() -> None:
    train, validation = synthetic(64, 0), synthetic(32, 1)
    settings = StageSettings(steps=10, batch_size=32, learning_rate=1e-3, eval_every=10, weight_average=0.999)
    stage = QStage(train, validation, settings)
    starting = QEnsemble()  # what --init-from loads into the stage's network after it is built
    stage.network.load_state_dict(starting.state_dict())
    assert not torch.equal(stage.average.network.weights[0], starting.weights[0])
    stage.prepare()
    assert torch.equal(stage.average.network.weights[0], starting.weights[0])


def test_an_averaged_run_selects_and_saves_the_average_and_resumes_it_after_a_kill(tmp_path) -> None:
    from t2m_skills_tableenv.checkpoints import load_weights

    train, validation = synthetic(512, 0), synthetic(128, 1)
    settings = StageSettings(steps=40, batch_size=32, learning_rate=1e-3, eval_every=10, weight_average=0.9)

    def stage() -> QStage:
        torch.manual_seed(settings.seed)
        return QStage(train, validation, settings)

    whole_stage = stage()
    averaged, trained = {}, {}

    def snapshot(step, record):
        averaged[step] = whole_stage.average.network.weights[0].detach().clone()
        trained[step] = whole_stage.network.weights[0].detach().clone()

    whole = run_stage(whole_stage, settings, tmp_path / "whole", on_progress=snapshot)
    saved = QEnsemble()
    load_weights(tmp_path / "whole" / "q_ensemble.safetensors", saved)
    # the saved weights are the average at the best evaluation, not the trained weights
    assert torch.equal(saved.weights[0], averaged[whole["best_step"]])
    assert not torch.equal(averaged[whole["best_step"]], trained[whole["best_step"]])

    _killed_at_step_20(stage(), settings, tmp_path / "killed")
    resumed_stage = stage()
    resumed = run_stage(resumed_stage, settings, tmp_path / "killed")
    assert resumed["best"] == pytest.approx(whole["best"], rel=1e-5)
    assert torch.equal(resumed_stage.average.network.weights[0], whole_stage.average.network.weights[0])


def test_a_run_with_other_settings_does_not_mix_with_a_saved_state(tmp_path) -> None:
    train, validation = synthetic(256, 0), synthetic(64, 1)
    settings = StageSettings(steps=10, batch_size=32, learning_rate=1e-3, eval_every=10)
    run_stage(QStage(train, validation, settings), settings, tmp_path)
    other = settings.model_copy(update={"learning_rate": 5e-4})
    with pytest.raises(T2MError, match="other settings") as refused:
        run_stage(QStage(train, validation, other), other, tmp_path)
    assert "delete" in refused.value.hint  # the way out is named


def test_a_state_saved_before_a_settings_field_existed_still_resumes() -> None:
    from t2m_skills_tableenv.training import _saved_settings

    settings = StageSettings(steps=10, batch_size=32, learning_rate=1e-3, eval_every=10)
    older = {k: v for k, v in settings.model_dump().items() if k not in ("selection_episodes", "train_size")}
    assert _saved_settings(older) == settings.model_dump()
    assert _saved_settings({**older, "learning_rate": 5e-4}) != settings.model_dump()
    assert _saved_settings({**older, "unknown": 1}) is None and _saved_settings(None) is None


def test_shuffling_permutes_only_the_rows_in_each_samples_range() -> None:
    rows = torch.arange(3 * 8, dtype=torch.float32).reshape(3, 8, 1).expand(3, 8, 12).clone()
    ranges = torch.tensor([[2, 6], [3, 4], [1, 8]])
    generator = torch.Generator().manual_seed(0)
    seen_changes = 0
    for _ in range(20):
        shuffled = shuffle_rows(rows, ranges, generator)
        for sample, (start, stop) in enumerate(ranges.tolist()):
            torch.testing.assert_close(shuffled[sample, :start], rows[sample, :start])
            torch.testing.assert_close(shuffled[sample, stop:], rows[sample, stop:])
            assert sorted(shuffled[sample, start:stop, 0].tolist()) == rows[sample, start:stop, 0].tolist()
            seen_changes += int(not torch.equal(shuffled[sample], rows[sample]))
    assert seen_changes > 20


def _situations(count: int, seed: int, new: bool) -> SkillTensors:
    """The synthetic problem's old situation (row 0, feature 1 in [−0.5, 0]: success when a₀ > 2·s₀) or a
    new one (feature 1 in [0.25, 0.5], where the rule is reversed: success when a₀ < 2·s₀)."""
    data = synthetic(count, seed)
    low = 0.25 if new else -0.5
    data.rows[:, 0, 1] = low + 0.25 * (1 + (not new)) * torch.rand(count, generator=torch.Generator().manual_seed(seed + 100))
    if new:
        data.rewards = 1.0 - data.rewards
    return data


def _accuracy(network: QEnsemble, data: SkillTensors) -> float:
    return q_metrics(network, data)["accuracy"]


def test_anchored_fine_tuning_learns_the_new_situation_without_forgetting_the_old(tmp_path) -> None:
    old_train, old_validation = _situations(2048, 0, False), _situations(512, 1, False)
    new_train, new_validation = _situations(1024, 2, True), _situations(512, 3, True)
    settings = StageSettings(steps=800, batch_size=128, learning_rate=3e-3, eval_every=800)
    teacher = QStage(old_train, old_validation, settings)
    run_stage(teacher, settings, tmp_path / "teacher")
    assert _accuracy(teacher.network, old_validation) > 0.85 and _accuracy(teacher.network, new_validation) < 0.3

    def fine_tuned(anchor: Anchor | None, directory: str) -> QEnsemble:
        network = QEnsemble()
        network.load_state_dict(teacher.network.state_dict())
        stage = QStage(new_train, new_validation, settings, network, anchor)
        run_stage(stage, settings, tmp_path / directory)
        return stage.network

    plain = fine_tuned(None, "plain")
    anchored = fine_tuned(Anchor(old_train, teacher.network.eval(), 1.0), "anchored")
    assert _accuracy(plain, new_validation) > 0.8 and _accuracy(anchored, new_validation) > 0.8
    # fine-tuning on the new situation alone forgets the old one; the anchor keeps it
    assert _accuracy(plain, old_validation) < 0.6
    assert _accuracy(anchored, old_validation) > 0.85
    curve = [json.loads(line) for line in (tmp_path / "anchored" / "metrics-q.jsonl").read_text().splitlines()]
    assert "train_anchor_loss" in curve[-1]


def test_anchor_data_need_a_starting_ensemble_and_labelled_data(tmp_path) -> None:
    from t2m_skills_tableenv.training import train_skill

    with pytest.raises(T2MError, match="--init-from"):
        train_skill("pick", ("q",), tmp_path / "data", tmp_path / "out", anchor=(tmp_path / "old",))
    for models in (("policy",), ("q", "policy", "dynamics")):  # the other models would lose the anchor splits
        with pytest.raises(T2MError, match="--model q"):
            train_skill("pick", models, tmp_path / "data", tmp_path / "out", init_from=tmp_path / "ship", anchor=(tmp_path / "old",))
    with pytest.raises(T2MError, match="nothing is left to learn"):
        train_skill("pick", ("q",), tmp_path / "data", tmp_path / "out", init_from=tmp_path / "ship", anchor=(tmp_path / "data",))


def _invalid_pairs(count: int, seed: int) -> SkillTensors:
    """Pairs no valid call produces: the synthetic problem's states with one feature far outside the
    encoding's [−0.5, 0.5] (row 1, feature 6 at 1.5), as a symbolically invalid call's rows are."""
    data = synthetic(count, seed)
    data.rows[:, 1, 6] = 1.5
    data.rewards = torch.zeros(count)
    return data


def _member_variance(network: QEnsemble, data: SkillTensors) -> torch.Tensor:
    with torch.no_grad():
        return network.probabilities(data.states(), data.actions).var(dim=1, unbiased=False)


def test_ood_exposure_makes_the_members_disagree_on_invalid_pairs_and_keeps_the_valid_predictions(tmp_path) -> None:
    from t2m_skills_tableenv.calibration import choose_threshold
    from t2m_skills_tableenv.training import Exposure

    torch.manual_seed(0)
    train, validation = synthetic(2048, 0), synthetic(512, 1)
    exposed, held_out = _invalid_pairs(2048, 2), _invalid_pairs(512, 3)
    settings = StageSettings(steps=600, batch_size=128, learning_rate=3e-3, eval_every=300)
    teacher = QStage(train, validation, settings)
    run_stage(teacher, settings, tmp_path / "teacher")
    teacher_threshold = choose_threshold(
        teacher.network.probabilities(validation.states(), validation.actions).mean(dim=1).detach().numpy(),
        _member_variance(teacher.network, validation).numpy(),
    )
    assert float((_member_variance(teacher.network, held_out) >= teacher_threshold).float().mean()) < 0.5

    network = QEnsemble()
    network.load_state_dict(teacher.network.state_dict())
    # no labelled data: the teacher's own predictions on the train states, and the exposure
    stage = QStage(train, validation, settings, network, Anchor(train, teacher.network.eval(), 1.0), Exposure(exposed, 1.0), labelled=False)
    run_stage(stage, settings, tmp_path / "exposed")
    variance = _member_variance(stage.network, held_out)
    # members b mod 2 learn 0 and 1 there: the variance of four 0s and four 1s is 0.25
    assert float(variance.mean()) > 0.2
    probabilities = stage.network.probabilities(validation.states(), validation.actions).detach()
    threshold = choose_threshold(probabilities.mean(dim=1).numpy(), _member_variance(stage.network, validation).numpy())
    assert float((variance >= threshold).float().mean()) > 0.9
    assert float(probabilities.min(dim=1).values.mean()) >= 0.0
    assert _accuracy(stage.network, validation) > _accuracy(teacher.network, validation) - 0.03
    curve = [json.loads(line) for line in (tmp_path / "exposed" / "metrics-q.jsonl").read_text().splitlines()]
    assert "train_exposure_loss" in curve[-1] and "train_loss" not in curve[-1] and curve[-1]["exposure_variance"] > 0.2
    held_minimum = stage.network.probabilities(held_out.states(), held_out.actions).min(dim=1).values.detach()
    assert float(held_minimum.max()) < 0.5  # planning's pessimistic value still rejects every one


def test_an_ensemble_is_distilled_into_a_fresh_relational_one_member_for_member(tmp_path) -> None:
    from t2m_skills_tableenv.networks import RelationalQEnsemble, q_architecture, build_q

    torch.manual_seed(0)
    train, validation = synthetic(2048, 0), synthetic(512, 1)
    settings = StageSettings(steps=600, batch_size=128, learning_rate=3e-3, eval_every=300)
    teacher = QStage(train, validation, settings)
    run_stage(teacher, settings, tmp_path / "teacher")
    student = build_q(q_architecture("pick", "relational"))
    assert isinstance(student, RelationalQEnsemble)

    def member_decisions(network: torch.nn.Module) -> torch.Tensor:
        with torch.no_grad():
            return network.probabilities(validation.states(), validation.actions) > 0.5  # (N, B)

    target = member_decisions(teacher.network)
    assert float((member_decisions(student) == target).float().mean()) < 0.7  # a fresh network does not agree yet
    stage = QStage(train, validation, settings, student, Anchor(train, teacher.network.eval(), 1.0), labelled=False)
    run_stage(stage, settings, tmp_path / "student")
    # each member learns its own teacher member's answers, not the labels' (the teacher's members differ)
    assert float((member_decisions(stage.network) == target).float().mean()) > 0.9
    assert _accuracy(stage.network, validation) > 0.8


def test_an_unlabelled_q_stage_needs_anchors_and_exposure_needs_the_q_ensemble(tmp_path) -> None:
    from t2m_skills_tableenv.training import train_skill

    settings = StageSettings(steps=10, batch_size=8, learning_rate=1e-3)
    with pytest.raises(ValueError, match="anchor"):
        QStage(synthetic(64, 0), synthetic(64, 1), settings, labelled=False)
    with pytest.raises(T2MError, match="--model q"):
        train_skill("pick", ("dynamics",), tmp_path / "data", tmp_path / "out", ood_exposure=(tmp_path / "invalid",))


def test_calibration_refuses_the_invalid_split_the_ensemble_was_exposed_to(tmp_path) -> None:
    from t2m_skills_tableenv.calibration import _refuse_exposed_pairs
    from t2m_skills_tableenv.checkpoints import update_config

    update_config(tmp_path, skill="pick", models={"q": {"data": {"ood_exposure": ["abc"]}}})
    _refuse_exposed_pairs(tmp_path, tmp_path / "other" / "pick" / "invalid", "def")  # another split: fine
    with pytest.raises(T2MError, match="(?s)exposed to in training.*another --seed"):
        _refuse_exposed_pairs(tmp_path, tmp_path / "data" / "pick" / "invalid", "abc")



class _TwoPeaks(torch.nn.Module):
    """A test-double ensemble: success depends on the action's first component only, with a lower
    peak at 0 (where a fresh policy acts) and a higher one at −0.7; the members differ slightly."""

    def probabilities(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        a = actions[:, :1]
        spread = torch.linspace(0.98, 1.0, 8)
        return spread * torch.maximum(0.6 * torch.exp(-a.square() / 0.05), 0.95 * torch.exp(-(a + 0.7).square() / 0.05))


class _Flat(torch.nn.Module):
    """A test-double ensemble that rates every action 0.5: no gradient for the actor to follow."""

    def probabilities(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        return 0.5 + 0.0 * actions[:, :1].expand(-1, 8)


def test_searched_targets_are_never_valued_below_the_policys_action_and_identical_states_share_one() -> None:
    from t2m_skills_tableenv.networks import GaussianPolicy
    from t2m_skills_tableenv.training import searched_actions

    torch.manual_seed(0)
    policy, q = GaussianPolicy(), _TwoPeaks()
    rows = synthetic(64, 3).rows
    rows[32:] = rows[:32]  # every state twice
    progress: list[tuple[int, int]] = []
    targets = searched_actions(policy, q, rows, 256, 0.3, torch.Generator().manual_seed(0), pairs_per_batch=257 * 10,
                               on_progress=lambda done, total: progress.append((done, total))).actions
    assert progress == [(10, 32), (20, 32), (30, 32), (32, 32)]  # 32 distinct states, 10 per batch
    states = rows.reshape(64, -1)
    with torch.no_grad():
        own = q.probabilities(states, policy(states)).min(dim=1).values
    found = q.probabilities(states, targets).min(dim=1).values
    assert targets.shape == (64, 4) and targets.abs().max() <= 1.0
    assert bool((found >= own).all())
    assert bool((own < 0.6).all()) and (found > 0.7).float().mean() > 0.9  # the higher peak, 0.7 away
    torch.testing.assert_close(targets[32:], targets[:32])
    again = searched_actions(policy, q, rows, 256, 0.3, torch.Generator().manual_seed(0))
    torch.testing.assert_close(again.actions, targets)
    # the own action stays the target unless a copy beats it by the margin (no value here exceeds 0.95)
    with torch.no_grad():
        own_actions = policy(states)
    kept = searched_actions(policy, q, rows, 256, 0.3, torch.Generator().manual_seed(0), margin=1.0)
    torch.testing.assert_close(kept.actions, own_actions)
    assert not kept.moved.any()
    moved = searched_actions(policy, q, rows, 256, 0.3, torch.Generator().manual_seed(0), margin=0.2)
    gained = found >= own + 0.2
    assert gained.float().mean() > 0.9
    torch.testing.assert_close(moved.actions[gained], targets[gained])
    torch.testing.assert_close(moved.actions[~gained], own_actions[~gained])
    assert torch.equal(moved.moved, gained)  # flagged exactly where a copy displaced the own action


class _FarPeak(torch.nn.Module):
    """A test-double ensemble that rates only actions whose first component lies near +0.9 (0.99;
    elsewhere 0.1)."""

    def probabilities(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        return (0.1 + 0.89 * ((actions[:, :1] - 0.9).abs() < 0.1).float()).expand(-1, 8)


def test_a_uniform_share_of_the_copies_reaches_an_optimum_the_local_noise_never_does() -> None:
    from t2m_skills_tableenv.networks import GaussianPolicy
    from t2m_skills_tableenv.training import searched_actions

    torch.manual_seed(0)
    policy, q = GaussianPolicy(), _FarPeak()
    rows = synthetic(32, 3).rows
    states = rows.reshape(32, -1)
    with torch.no_grad():
        own = policy(states)
    assert bool((own[:, 0].abs() < 0.5).all())  # a fresh policy acts near 0, far from the peak
    local = searched_actions(policy, q, rows, 256, 0.01, torch.Generator().manual_seed(0)).actions
    torch.testing.assert_close(local, own)  # σ = 0.01 never leaves the flat 0.1
    spread = searched_actions(policy, q, rows, 256, 0.01, torch.Generator().manual_seed(0), uniform=0.5).actions
    assert bool(((spread[:, 0] - 0.9).abs() < 0.1).all())  # 128 uniform copies: P(none within 0.1) = 0.95¹²⁸
    assert spread.abs().max() <= 1.0


class _Disputed(torch.nn.Module):
    """A test-double ensemble with two peaks of the action's first component: at −0.5 every member
    says 0.7; at +0.5 half say 1.0 and half 0.5 (a higher mean, a lower minimum)."""

    def probabilities(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        a = actions[:, :1]
        agreed = 0.7 * torch.exp(-(a + 0.5).square() / 0.05).expand(-1, 8)
        disputed = torch.tensor([1.0, 0.5] * 4) * torch.exp(-(a - 0.5).square() / 0.05)
        return torch.maximum(agreed, disputed)


@pytest.mark.parametrize(("value", "side"), [("min", -1.0), ("mean", 1.0)])
def test_searched_targets_rank_by_the_members_minimum_or_mean(value, side) -> None:
    from t2m_skills_tableenv.networks import GaussianPolicy
    from t2m_skills_tableenv.training import searched_actions

    torch.manual_seed(0)
    rows = synthetic(32, 4).rows
    targets = searched_actions(GaussianPolicy(), _Disputed(), rows, 512, 0.3, torch.Generator().manual_seed(0), value=value).actions
    assert (torch.sign(targets[:, 0]) == side).float().mean() > 0.9
    assert (targets[:, 0] - 0.5 * side).abs().median() < 0.1


class _TwinPeaks(torch.nn.Module):
    """A test-double ensemble valuing the action's first component at ±0.6 equally (1.0 within 0.15 of
    either, 0.2 elsewhere)."""

    def probabilities(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        return (0.2 + 0.8 * ((actions[:, :1].abs() - 0.6).abs() < 0.15).float()).expand(-1, 8)


def test_a_tolerance_sends_every_target_to_the_nearest_of_two_equal_optima() -> None:
    from t2m_skills_tableenv.networks import GaussianPolicy
    from t2m_skills_tableenv.training import searched_actions

    torch.manual_seed(0)
    policy, rows = GaussianPolicy(), synthetic(64, 5).rows
    with torch.no_grad():
        own = policy(rows.reshape(64, -1))
    between = own[:, 0].abs() < 0.4  # between the peaks, both within the noise's reach
    assert between.sum() >= 32
    best = searched_actions(policy, _TwinPeaks(), rows, 512, 0.5, torch.Generator().manual_seed(0))
    near = searched_actions(policy, _TwinPeaks(), rows, 512, 0.5, torch.Generator().manual_seed(0), tolerance=0.01)
    assert bool(best.moved[between].all() and near.moved[between].all())
    own_side = torch.sign(own[:, 0])
    assert 0.2 < float((torch.sign(best.actions[between, 0]) == own_side[between]).float().mean()) < 0.8  # the first-ranked: either side
    closer = between & (own[:, 0].abs() > 0.1)  # clearly nearer its own side's peak
    assert closer.sum() >= 10 and bool((torch.sign(near.actions[closer, 0]) == own_side[closer]).all())
    moved_best = (best.actions - own).square().sum(-1)[between]
    moved_near = (near.actions - own).square().sum(-1)[between]
    assert float(moved_near.mean()) < 0.5 * float(moved_best.mean())  # the smallest move that reaches the optimum


@pytest.mark.parametrize("weight", [0.0, 1.0])
def test_the_policy_is_pulled_towards_its_targets_by_their_weight(tmp_path, weight) -> None:
    train, validation = synthetic(1024, 0), synthetic(256, 1)
    settings = StageSettings(steps=300, batch_size=128, learning_rate=3e-3, eval_every=100, policy_targets=16, policy_target_weight=weight)
    torch.manual_seed(0)
    stage = PolicyStage(train, validation, _Flat(), settings)
    stage.prepare()
    assert stage.targets is not None and stage.targets.shape == (1024, 4)
    stage.targets = torch.full((1024, 4), 0.5)  # known targets: the ensemble gives no direction of its own
    run_stage(stage, settings, tmp_path)
    with torch.no_grad():
        distance = (stage.network(train.states()) - 0.5).abs().max()
    assert (distance < 0.1) if weight else (distance > 0.2)


def test_focused_batches_draw_their_share_from_the_moved_states_and_fit_them_sooner(tmp_path) -> None:
    train, validation = synthetic(1024, 0), synthetic(256, 1)
    fitted = {}
    for focus in (0.0, 0.5):
        settings = StageSettings(steps=100, batch_size=128, learning_rate=3e-3, eval_every=100, policy_targets=16, policy_target_focus=focus)
        torch.manual_seed(0)
        stage = PolicyStage(train, validation, _Flat(), settings)
        stage.prepare()
        assert len(stage.moved) == 0  # a flat ensemble never prefers a copy to the own action
        with torch.no_grad():
            stage.targets = stage.network(train.states())  # keep every action where it is ...
        stage.moved = torch.arange(8) * 100  # ... except 8 of the 1 024 states, sent to a corner
        stage.targets[stage.moved] = 0.9
        index = stage.batch(128, torch.Generator().manual_seed(1))
        assert index.shape == (128,) and int(torch.isin(index, stage.moved).sum()) >= round(focus * 128)
        run_stage(stage, settings, tmp_path / str(focus))
        fitted[focus] = stage.evaluate().metrics["moved_target_distance"]
    assert fitted[0.5] < 0.2 * fitted[0.0]


def test_a_killed_policy_run_with_searched_targets_resumes_to_the_same_policy(tmp_path) -> None:
    train, validation = synthetic(256, 0), synthetic(64, 1)
    settings = StageSettings(steps=40, batch_size=32, learning_rate=1e-3, eval_every=10, policy_targets=32)

    def stage() -> PolicyStage:
        torch.manual_seed(5)  # the same starting weights each time, as --init-from would give
        made = PolicyStage(train, validation, _TwoPeaks(), settings)
        made.prepare()
        return made

    whole = stage()
    run_stage(whole, settings, tmp_path / "whole")

    _killed_at_step_20(stage(), settings, tmp_path / "killed")
    resumed = stage()  # searches again from the starting weights, then loads the saved state
    torch.testing.assert_close(resumed.targets, whole.targets)
    run_stage(resumed, settings, tmp_path / "killed")
    states = validation.states()
    with torch.no_grad():
        torch.testing.assert_close(resumed.network(states), whole.network(states))


def test_the_calibration_plot_marks_empty_mean_bins_without_warnings(tmp_path) -> None:
    import warnings

    from PIL import Image

    from t2m_skills_tableenv.calibration import plot_calibration

    # every pair in the lowest mean bin: the other nine bins have nothing to plot or label
    valid = (np.full(50, 0.05), np.full(50, 1e-4))
    invalid = (np.full(80, 0.02), np.full(80, 1e-6))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plot_calibration(tmp_path / "ood.png", "push", valid, invalid, 1e-3)
    assert Image.open(tmp_path / "ood.png").size[0] > 500
