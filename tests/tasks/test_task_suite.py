"""The seven-task suite (docs/guide/tasks.md) and its validating loader."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from t2m_core.domain.goals import validate_goal
from t2m_core.domain.propositions import PREDICATE_ORDER, canonical_order
from t2m_core.domain.skills import validate_skill_call
from t2m_core.domain.symbolic_effects import apply_effects, precondition_problems
from t2m_core.tasks import TaskFileError, TaskNotFoundError, list_tasks, load_task, load_task_file, parse_task, task_ids

DATA = Path(__file__).resolve().parents[2] / "t2m_core" / "tasks" / "data"

OVERVIEW = {
    # id: (name, properties, instruction, objects, rack zone, alternatives, skeleton length)
    "task0": ("lh_0", ("LH",), "How would you pick and place all of the boxes onto the rack?",
              ("table", "rack", "blue_box", "yellow_box", "cyan_box"), "inworkspace", 1, 6),
    "task1": ("lh_1", ("LH",), "How would you pick and place the yellow box and blue box onto the table, then use the "
              "hook to push the cyan box under the rack?",
              ("table", "rack", "hook", "cyan_box", "yellow_box", "blue_box"), "beyondworkspace", 1, 6),
    "task2": ("lh_lg_0", ("LH", "LG"), "How would you move three of the boxes to the rack?",
              ("table", "rack", "blue_box", "yellow_box", "red_box", "cyan_box"), "inworkspace", 4, 6),
    "task3": ("lh_lg_po_2", ("LH", "LG", "PAP"), "How would you put two primary colored boxes onto the rack?",
              ("table", "rack", "hook", "red_box", "cyan_box", "blue_box", "yellow_box"), "inworkspace", 3, 7),
    "task4": ("lg_po_0", ("LG", "PAP"), "How would you put one box on the rack (hint you may use a hook)?",
              ("table", "rack", "hook", "yellow_box", "red_box", "cyan_box", "blue_box"), "inworkspace", 4, 5),
    "task5": ("lh_lg_po_0", ("LH", "LG", "PAP"), "How would you get two boxes onto the rack?",
              ("table", "rack", "hook", "blue_box", "cyan_box", "yellow_box", "red_box"), "inworkspace", 6, 7),
    "task6": ("lh_lg_po_1", ("LH", "LG", "PAP"), "How would you move any three boxes to the rack?",
              ("table", "rack", "hook", "blue_box", "cyan_box", "yellow_box", "red_box"), "inworkspace", 4, 9),
}


def test_the_suite_matches_the_overview() -> None:
    tasks = list_tasks()
    assert task_ids() == tuple(OVERVIEW)
    assert [t.id for t in tasks] == list(OVERVIEW)
    for task in tasks:
        name, properties, instruction, objects, zone, alternatives, length = OVERVIEW[task.id]
        assert (task.name, task.properties, task.instruction, task.objects) == (name, properties, instruction, objects)
        assert task.rack_zone == zone
        assert len(task.goal) == alternatives
        assert len(task.reference_skeleton) == length
        assert task.source is not None and task.source.name == f"{task.id}.yaml"


def test_initial_states_are_stored_in_canonical_order() -> None:
    for path in sorted(DATA.glob("task*.yaml")):
        raw = yaml.safe_load(path.read_text())
        assert raw["initial_state"] == [str(p) for p in canonical_order(raw["initial_state"])], path.name
        assert raw["id"] == path.stem
    task1 = load_task("task1")
    assert task1.initial_state_strings[:9] == (
        "free(hook)", "free(cyan_box)", "aligned(rack)", "poslimit(rack)", "inworkspace(hook)",
        "inoperationalzone(cyan_box)", "inobstructionzone(yellow_box)", "inobstructionzone(blue_box)",
        "beyondworkspace(rack)",
    )
    assert all(PREDICATE_ORDER.index(p.predicate) >= 0 for p in task1.initial_state)


@pytest.mark.parametrize("task", list_tasks(), ids=lambda t: t.id)
def test_every_task_validates_and_its_skeleton_solves_it(task) -> None:
    validate_goal(task.goal, task.objects)
    assert {"aligned(rack)", "poslimit(rack)", "on(rack, table)", f"{task.rack_zone}(rack)"} <= set(
        task.initial_state_strings
    )
    facts = frozenset(p for p in task.initial_state if p.predicate in ("on", "inhand", "beyondworkspace"))
    for call in task.reference_skeleton:
        validate_skill_call(call, task.objects)
        assert precondition_problems(call, facts) == [], f"{task.id}: {call}"
        facts = apply_effects(call, facts)
    assert task.goal.satisfied_by(facts)


def test_task3_skeleton_is_the_corrected_one() -> None:
    task = load_task("task3")
    assert "cyan_box" not in " ".join(str(c) for c in task.reference_skeleton)
    assert [str(c) for c in task.reference_skeleton][3] == "pull(blue_box, hook)"
    swap = {"blue_box": "cyan_box"}
    original = [type(c)(c.name, tuple(swap.get(a, a) for a in c.args)) for c in task.reference_skeleton]
    facts = frozenset(p for p in task.initial_state if p.predicate == "on")
    for call in original:
        facts = apply_effects(call, facts)
    assert not task.goal.satisfied_by(facts)  # why the original's stored skeleton needed correcting


def test_goal_alternatives_in_detail() -> None:
    assert load_task("task1").goal.to_lists() == [["under(cyan_box, rack)"]]
    task4 = load_task("task4").goal.to_lists()
    assert task4[3] == ["on(red_box, table)", "on(yellow_box, table)", "on(cyan_box, table)", "on(blue_box, rack)"]
    pairs = {frozenset(p.split("(")[1].split(",")[0] for p in alt) for alt in load_task("task5").goal.to_lists()}
    assert len(pairs) == 6 and all(len(p) == 2 for p in pairs)
    assert load_task("task3").goal.to_lists()[0] == ["on(red_box, rack)", "on(yellow_box, rack)"]


def test_load_task_lookups() -> None:
    assert load_task("3").id == "task3"
    assert load_task("lh_lg_po_2").id == "task3"
    assert load_task(str(DATA / "task0.yaml")).name == "lh_0"
    with pytest.raises(TaskNotFoundError, match="did you mean 'task3'") as caught:
        load_task("tsak3")
    assert "task0, task1, task2, task3, task4, task5, task6" in str(caught.value)
    with pytest.raises(TaskNotFoundError, match="did you mean 'lh_lg_po_2'"):
        load_task("lh_lg_po2")


def test_summary_is_json_ready() -> None:
    summary = load_task("task0").summary()
    assert summary["goal"] == [["on(yellow_box, rack)", "on(cyan_box, rack)", "on(blue_box, rack)"]]
    assert summary["reference_skeleton"][0] == "pick(yellow_box)"
    assert summary["paper_task"] == 1


# --------------------------------------------------------------------------------------------------
# Loader errors
# --------------------------------------------------------------------------------------------------

VALID = (DATA / "task0.yaml").read_text()


def _broken(tmp_path: Path, old: str, new: str) -> Path:
    assert old in VALID
    path = tmp_path / "broken.yaml"
    path.write_text(VALID.replace(old, new, 1))
    return path


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("rack_zone: inworkspace", "rack_zone: inworkspace\nseed: 3", "key 'seed': unknown key"),
        ("objects: [table, rack, blue_box,", "objects: [table, rack, green_box,",
         "key 'objects[2]': unknown object 'green_box'"),
        ("  - free(yellow_box)", "  - clear(yellow_box)", "key 'initial_state[0]': unknown predicate 'clear'"),
        ("  - free(yellow_box)", "  - free(red_box)", "key 'initial_state[0]': unknown object 'red_box'"),
        ("  - free(yellow_box)", "  - free(yellow_box", "key 'initial_state[0]': expected ',' or ')'"),
        ('"on(cyan_box, rack)"', "on(cyan_box, rack)", "key 'goal[0][1]'"),
        ('"on(cyan_box, rack)"', '"inhand(cyan_box, rack)"', "key 'goal': invalid goal proposition"),
        ("  - place(yellow_box, rack)", "  - place(yellow_box, blue_box)",
         ("key 'reference_skeleton[1]'", "blue_box is not a support")),
        ("  - pick(yellow_box)", "  - grab(yellow_box)", ("key 'reference_skeleton[0]'", "unknown skill 'grab'")),
        ("rack_zone: inworkspace", "rack_zone: beyondworkspace", "key 'rack_zone'"),
        ("rack_zone: inworkspace", "rack_zone: nowhere", "key 'rack_zone'"),
        ("properties: [LH]", "properties: [XL]", "key 'properties[0]'"),
        ("instruction: How", "instruction:\ninstruction2: How", "key 'instruction'"),
    ],
)
def test_invalid_task_files_name_the_file_and_key(tmp_path: Path, old: str, new: str, message) -> None:
    path = _broken(tmp_path, old, new)
    with pytest.raises(TaskFileError) as caught:
        load_task_file(path)
    text = str(caught.value)
    assert text.startswith(f"{path}: key '")
    for fragment in (message,) if isinstance(message, str) else message:
        assert fragment in text


def test_unreadable_and_non_mapping_files(tmp_path: Path) -> None:
    with pytest.raises(TaskFileError, match="cannot read task file"):
        load_task_file(tmp_path / "missing.yaml")
    with pytest.raises(TaskFileError, match="must be a mapping"):
        parse_task("- just\n- a list\n", source="list.yaml")
    with pytest.raises(TaskFileError, match="invalid YAML"):
        parse_task("id: [unclosed\n", source="bad.yaml")


def test_a_custom_task_file_loads(tmp_path: Path) -> None:
    text = VALID.replace("id: task0", "id: kitchen").replace("paper_task: 1\n", "").replace(
        "instruction: How would you pick and place all of the boxes onto the rack?",
        "instruction: '  Stack everything on the rack.  '",
    )
    path = tmp_path / "kitchen.yaml"
    path.write_text(text)
    task = load_task(str(path))
    assert (task.id, task.paper_task, task.instruction) == ("kitchen", None, "Stack everything on the rack.")
    assert task.boxes == ("blue_box", "yellow_box", "cyan_box") and not task.has_hook
