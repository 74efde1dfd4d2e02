"""Proposal data along task-suite rollouts (docs/guide/skills.md#task-rollouts), with the real
simulator and the shipped skill library."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from t2m_core.data.chunks import ChunkSpec, DataGenerationError, ProposalSource, generate_chunk
from t2m_core.data.generate import DatasetJob, _existing_header, _require_same_dataset, write_manifest
from t2m_core.data.proposals import library_digest
from t2m_core.data.rollouts import NOT_ENUMERATED, TASK_SEED_FLOOR, rollout_tasks
from t2m_core.data.scenes import DATA_SKILLS
from t2m_core.domain.skills import parse_skeleton
from t2m_core.registry import get_registry

SKILLS = ("pick", "place", "pull", "push")


@pytest.fixture(scope="module")
def shipped():
    directory = get_registry().get("skill_library", "tableenv").options().checkpoint_directory
    return ProposalSource("tableenv", str(directory), library_digest(directory, DATA_SKILLS))


def test_rollout_tasks_are_those_whose_reference_skeleton_calls_the_skill() -> None:
    assert {t.id for t in rollout_tasks("push")} == {"task1"}  # the one task that pushes a box under the rack
    assert len(rollout_tasks("place")) == 7
    for task in rollout_tasks("pull"):
        assert "pull" in [call.name for call in task.reference_skeleton]


def test_a_rollout_chunk_is_deterministic_and_starts_from_reached_states(shipped) -> None:
    spec = ChunkSpec("place", "train", 0, 6, sampler="proposal", actions_per_scene=3, proposal=shipped, scenes="tasks")
    first, _ = generate_chunk(spec, get_registry().create("simulator", "mujoco"))
    simulator = get_registry().create("simulator", "mujoco")
    again, _ = generate_chunk(spec, simulator)
    for name, column in first.columns().items():
        np.testing.assert_array_equal(column, again.columns()[name], err_msg=name)
    assert np.all(first.symbolic_state == NOT_ENUMERATED)
    assert np.all(first.scene_seed >= TASK_SEED_FLOOR)
    for row in range(len(first)):
        # a place starts with the object in hand: a pick ran before it, so the row's state is not the
        # task scene the seed resets to
        held = first.argument_names(row)[0]
        candidates = [t for t in rollout_tasks("place") if set(first.object_names(row)) == set(t.objects)]
        assert candidates, first.object_names(row)
        task = candidates[0]
        reset = simulator.reset(task, seed=int(first.scene_seed[row]))
        assert held in task.objects
        assert not np.allclose(reset.observation, first.observation[row], atol=1e-3)


def test_task_scenes_need_the_proposal_sampler_and_a_simulated_split(shipped) -> None:
    with pytest.raises(DataGenerationError, match="proposal or planned sampler"):
        ChunkSpec("place", "train", 0, 5, scenes="tasks")
    with pytest.raises(DataGenerationError, match="unknown scene source"):
        ChunkSpec("place", "train", 0, 5, scenes="kitchen")
    # the invalid split is not simulated: a task-scene job makes its usual invalid chunks
    job = DatasetJob("/tmp/unused", "place", "invalid", 10, sampler="proposal", proposal=shipped, scenes="tasks")
    assert all(spec.scenes == "data" and spec.proposal is None for spec in job.chunks())


def test_a_task_rollout_dataset_is_never_mixed_with_data_scenes(tmp_path, shipped) -> None:
    rollout = DatasetJob(tmp_path, "place", "train", 6, chunk_size=6, sampler="proposal", actions_per_scene=3, proposal=shipped, scenes="tasks")
    from t2m_core.data.generate import make_chunk

    make_chunk(rollout, rollout.chunks()[0])
    write_manifest(rollout)
    assert json.loads((rollout.directory / "manifest.json").read_text())["scenes"] == "tasks"
    plain = DatasetJob(tmp_path, "place", "train", 6, chunk_size=6, sampler="proposal", actions_per_scene=3,
                       proposal=ProposalSource("tableenv", shipped.checkpoints, shipped.digest))
    assert _existing_header(plain, plain.chunks()[0]) is None  # its shard is not one of the plain job's
    with pytest.raises(DataGenerationError, match="scenes 'tasks'"):
        _require_same_dataset(plain)


def test_the_library_digest_changes_with_any_skill_checkpoint(tmp_path, shipped) -> None:
    root = tmp_path / "checkpoints"
    shutil.copytree(shipped.checkpoints, root)
    before = library_digest(root, SKILLS)
    assert before == shipped.digest
    config = root / "push" / "config.json"
    config.write_text(config.read_text() + "\n")
    assert library_digest(root, SKILLS) != before



def test_rollouts_can_be_restricted_to_named_tasks(shipped) -> None:
    assert [t.id for t in rollout_tasks("place", ("task2", "task0"))] == ["task0", "task2"]
    spec = ChunkSpec("place", "train", 0, 4, sampler="proposal", actions_per_scene=2, proposal=shipped, scenes="tasks:task2")
    rows, _ = generate_chunk(spec, get_registry().create("simulator", "mujoco"))
    task2_places = {call.args for call in rollout_tasks("place", ("task2",))[0].reference_skeleton if call.name == "place"}
    assert {rows.argument_names(i) for i in range(len(rows))} <= task2_places
    assert spec.header()["scenes"] == "tasks:task2"  # what the data depend on is recorded
    with pytest.raises(DataGenerationError, match="no shipped task task9"):
        ChunkSpec("place", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="tasks:task9")
    with pytest.raises(DataGenerationError, match="calls pull"):
        ChunkSpec("pull", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="tasks:task0,task1")


def _position(observation: np.ndarray, names: tuple[str, ...], name: str) -> np.ndarray:
    """``(3,)`` the object's position in an ``(8, 12)`` observation whose rows 1.. are ``names``."""
    return observation[1 + names.index(name), :3]


def test_a_rollout_can_walk_another_order_of_a_task(shipped) -> None:
    # task3's reference moves the red box first; a planner may pull the blue box while red is still
    # on the table, so the pulls of this order start with red where the reset put it
    order = "pick(hook), pull(blue_box, hook), place(hook, table), pick(blue_box), place(blue_box, rack)"
    spec = ChunkSpec("pull", "train", 0, 3, sampler="proposal", actions_per_scene=3, proposal=shipped, scenes="tasks:task3", skeleton=order)
    simulator = get_registry().create("simulator", "mujoco")
    rows, _ = generate_chunk(spec, simulator)
    assert spec.header()["skeleton"] == order
    task3 = rollout_tasks("pull", ("task3",))[0]
    for row in range(len(rows)):
        assert rows.argument_names(row) == ("blue_box", "hook")
        reset = simulator.reset(task3, seed=int(rows.scene_seed[row]))
        names = rows.object_names(row)
        reset_names = tuple(reset.state.object_names)
        np.testing.assert_allclose(_position(rows.observation[row], names, "red_box"),
                                   _position(reset.observation, reset_names, "red_box"), atol=2e-3)
        # the hook was picked first: it is not where the reset put it
        assert not np.allclose(_position(rows.observation[row], names, "hook"), _position(reset.observation, reset_names, "hook"), atol=1e-2)


def test_a_rollout_skeleton_is_checked_and_keeps_its_dataset_apart(tmp_path, shipped) -> None:
    order = "pick(hook), pull(blue_box, hook)"
    with pytest.raises(DataGenerationError, match="scenes of one task"):
        ChunkSpec("pull", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="tasks", skeleton=order)
    with pytest.raises(DataGenerationError, match="never calls place"):
        ChunkSpec("place", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="tasks:task3", skeleton=order)
    with pytest.raises(DataGenerationError, match="green_box"):
        ChunkSpec("pull", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="tasks:task3", skeleton="pick(hook), pull(green_box, hook)")
    with pytest.raises(DataGenerationError, match="no shipped task task9"):
        ChunkSpec("pull", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="tasks:task9", skeleton=order)
    with pytest.raises(DataGenerationError, match="unknown scene source 'kitchen'"):
        ChunkSpec("pull", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="kitchen", skeleton=order)
    # task1's reference never pulls (it pushes), but a skeleton of its objects may
    ChunkSpec("pull", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="tasks:task1", skeleton=order)
    with pytest.raises(DataGenerationError, match="calls pull"):
        ChunkSpec("pull", "train", 0, 4, sampler="proposal", proposal=shipped, scenes="tasks:task1")
    reference = DatasetJob(tmp_path, "pull", "train", 2, chunk_size=2, sampler="proposal", actions_per_scene=2, proposal=shipped, scenes="tasks:task3")
    from t2m_core.data.generate import make_chunk

    make_chunk(reference, reference.chunks()[0])
    write_manifest(reference)
    other = DatasetJob(tmp_path, "pull", "train", 2, chunk_size=2, sampler="proposal", actions_per_scene=2, proposal=shipped, scenes="tasks:task3",
                       skeleton=order)
    assert other.chunks()[0].header()["skeleton"] == order
    assert _existing_header(other, other.chunks()[0]) is None  # the reference order's shard is not this order's
    with pytest.raises(DataGenerationError, match="skeleton None"):
        _require_same_dataset(other)


def test_a_planned_rollout_executes_the_feasibility_planners_action_then_noisy_ones(shipped) -> None:
    order = "pick(red_box), place(red_box, rack)"
    spec = ChunkSpec("pick", "train", 0, 3, sampler="planned", actions_per_scene=3, proposal=shipped, scenes="tasks:task2", skeleton=order)
    rows, _ = generate_chunk(spec, get_registry().create("simulator", "mujoco"))
    assert spec.header()["sampler"] == "planned"
    # what the data depend on is recorded: the planner and its options (500 samples, docs/guide/feasibility.md)
    planner = spec.header()["planner"]
    assert planner["name"] == "policy-cem" and planner["options"]["population"] == 500 and planner["options"]["sigma"] == 0.3
    assert np.all(rows.scene_seed == rows.scene_seed[0])  # one scene: the pick is the skeleton's first call
    np.testing.assert_array_equal(rows.observation[1], rows.observation[0])
    # a run's planner, built apart from the data code, plans the same skeleton from the same state
    registry = get_registry()
    task2 = rollout_tasks("pick", ("task2",))[0]
    objects = rows.object_names(0)
    planner = registry.create("feasibility_planner", "policy-cem")
    skills = registry.create("skill_library", "tableenv")
    plan = planner.plan(rows.observation[0], list(parse_skeleton(order, task2.objects)), skills, objects)
    np.testing.assert_allclose(rows.action[0], plan.actions[0], atol=1e-6)
    for row in (1, 2):
        assert not np.allclose(rows.action[row], rows.action[0])
        assert np.all(np.abs(rows.action[row]) <= 1.0)
        assert np.abs(rows.action[row] - rows.action[0]).max() < 1.5  # PolicyCEM's sigma, not uniform draws


def test_the_planned_sampler_needs_task_scenes_and_a_library(shipped) -> None:
    with pytest.raises(DataGenerationError, match="task rollouts"):
        ChunkSpec("pick", "train", 0, 3, sampler="planned", proposal=shipped)
    with pytest.raises(DataGenerationError, match="need a proposal skill library"):
        ChunkSpec("pick", "train", 0, 3, sampler="planned", scenes="tasks")
    # the invalid split is never planned: its chunks are the usual uniform ones
    job = DatasetJob("/tmp/unused", "pick", "invalid", 10, sampler="planned", proposal=shipped, scenes="tasks")
    assert all(spec.header()["sampler"] == "uniform" for spec in job.chunks())


def test_planned_chunks_keep_every_failure_and_proposal_chunks_balance(shipped, monkeypatch) -> None:
    import t2m_core.data.chunks as chunks

    def failing_rollout(spec, simulator, rng, stats, skills, make_row):  # a double: every draw fails
        observation = np.zeros((8, 12), np.float32)
        for _ in range(spec.actions_per_scene):
            yield make_row(("table", "red_box"), ("red_box",), NOT_ENUMERATED, TASK_SEED_FLOOR, observation, np.zeros(4), observation,
                           bool(rng.random() < 0.1), False, "collision")

    monkeypatch.setattr(chunks, "task_rollout_rows", failing_rollout)
    planned, planned_stats = generate_chunk(ChunkSpec("pick", "train", 0, 40, sampler="planned", actions_per_scene=4, proposal=shipped, scenes="tasks"), object())
    assert planned_stats.discarded_failures == 0 and planned_stats.draws == 40
    assert planned.success.sum() < 16  # under the 40 % the balancing rule would have waited for
    balanced, stats = generate_chunk(ChunkSpec("pick", "train", 0, 40, sampler="proposal", actions_per_scene=4, proposal=shipped, scenes="tasks"), object())
    assert balanced.success.sum() == 16 and stats.discarded_failures > 0
