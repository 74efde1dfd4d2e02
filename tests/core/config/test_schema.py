"""The run configuration's JSON schema is valid and checks plugin options."""

from __future__ import annotations

import jsonschema
import pytest

from t2m_core.config import resolve_config, run_config_schema
from t2m_core.registry import Registry
from tests.core.plugin_doubles import EveryKind


def test_schema_is_valid_and_accepts_the_defaults() -> None:
    schema = run_config_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.validate(resolve_config().model_dump(mode="json"), schema)
    assert set(schema["properties"]) == {
        "task", "seed", "simulator", "language_model", "scene_parser", "skills",
        "feasibility_planner", "task_planner", "prompts", "run", "output",
    }  # fmt: skip
    with pytest.raises(jsonschema.ValidationError, match="'colour' was unexpected"):
        jsonschema.validate({"colour": "red"}, schema)


def test_schema_with_a_registry_checks_each_components_options() -> None:
    registry = Registry()
    registry.register_plugin(EveryKind(), name="every-kind")
    schema = run_config_schema(registry)
    jsonschema.Draft202012Validator.check_schema(schema)
    good = {"simulator": {"name": "toysim", "options": {"timestep": 0.01}}, "skills": None}
    jsonschema.validate(good, schema)
    with pytest.raises(jsonschema.ValidationError, match="0 is less than or equal to the minimum of 0"):
        jsonschema.validate({"simulator": {"name": "toysim", "options": {"timestep": 0}}}, schema)
    # another simulator's options are not constrained by toysim's model
    jsonschema.validate({"simulator": {"name": "other", "options": {"timestep": 0}}}, schema)
