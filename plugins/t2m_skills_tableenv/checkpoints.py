"""Checkpoint directories in the style of Hugging Face / LeRobot: ``config.json`` beside
``<model>.safetensors`` files (docs/guide/skills.md#checkpoints). Loading never unpickles; every file
is written atomically, and a missing, corrupt or mismatched file is an error that names it."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch
from torch import nn

from t2m_core.atomic_files import write_bytes_atomic, write_json_atomic
from t2m_core.errors import T2MError

CONFIG_NAME = "config.json"
CHECKPOINT_FORMAT = "t2m-skill/1"


class CheckpointError(T2MError):
    """A checkpoint file that is missing, unreadable or does not fit its model."""


def save_weights(path: Path, module: nn.Module, metadata: dict[str, str] | None = None) -> None:
    """Write ``module``'s parameters and buffers to a safetensors file, atomically."""
    from safetensors.torch import save

    tensors = {name: tensor.detach().contiguous().clone() for name, tensor in module.state_dict().items()}
    write_bytes_atomic(path, save(tensors, metadata=metadata))


def load_weights(path: Path, module: nn.Module) -> nn.Module:
    """Load a safetensors file written by :func:`save_weights` into ``module`` (strict).

    Raises:
        CheckpointError: missing or unreadable file, or tensors that do not fit the module.
    """
    from safetensors.torch import load_file

    if not path.exists():
        raise CheckpointError(f"checkpoint file {path} is missing", "train the model (`t2m train`) or reinstall t2m")
    try:
        tensors = load_file(str(path))
    except Exception as error:  # safetensors raises several types for a torn or foreign file
        raise CheckpointError(f"checkpoint file {path} is corrupt: {error}", "retrain it with `t2m train` or reinstall t2m") from None
    try:
        module.load_state_dict(tensors, strict=True)
    except RuntimeError as error:
        first = str(error).splitlines()[0]
        raise CheckpointError(f"checkpoint file {path} does not fit the {type(module).__name__} network: {first}", "retrain it with `t2m train`") from None
    return module


def read_config(directory: Path) -> dict[str, Any]:
    """A skill checkpoint's ``config.json``.

    Raises:
        CheckpointError: missing, not JSON, or another format.
    """
    path = Path(directory) / CONFIG_NAME
    if not path.exists():
        raise CheckpointError(f"no {CONFIG_NAME} in {directory}", "point at a skill checkpoint directory written by `t2m train`")
    try:
        config = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as error:
        raise CheckpointError(f"{path} is not valid JSON: {error}", "retrain the skill or reinstall t2m") from None
    if not isinstance(config, dict) or config.get("format") != CHECKPOINT_FORMAT:
        raise CheckpointError(f"{path} is not a {CHECKPOINT_FORMAT} skill checkpoint", "retrain the skill with `t2m train`")
    return config


def architecture_of(directory: Path, model: str) -> dict[str, Any]:
    """``models.<model>.architecture`` of the skill checkpoint ``directory``'s config (``{}``: none recorded).

    Raises:
        CheckpointError: a missing or broken config.
    """
    return read_config(directory).get("models", {}).get(model, {}).get("architecture", {})


def load_q(directory: Path) -> nn.Module:
    """The Q-ensemble of the skill checkpoint ``directory``, built as its ``config.json`` says
    (the MLP when the config names no architecture).

    Raises:
        CheckpointError: a missing or broken config or weight file, or an unknown architecture.
    """
    from t2m_skills_tableenv.networks import build_q

    return _load_model(Path(directory), "q", "Q-ensemble", build_q, "q_ensemble.safetensors")


def load_dynamics(directory: Path) -> nn.Module:
    """The dynamics model of the skill checkpoint ``directory``, built as its ``config.json`` says
    (the MLP when the config names no architecture).

    Raises:
        CheckpointError: a missing or broken config or weight file, or an unknown architecture.
    """
    from t2m_skills_tableenv.networks import build_dynamics

    return _load_model(Path(directory), "dynamics", "dynamics model", build_dynamics, "dynamics.safetensors")


def _load_model(directory: Path, model: str, description: str, build: Callable[[dict[str, Any]], nn.Module], file: str) -> nn.Module:
    try:
        network = build(architecture_of(directory, model))
    except (ValueError, KeyError, TypeError) as error:
        raise CheckpointError(f"{directory / CONFIG_NAME} describes a {description} this t2m cannot build: {error}", "retrain it with `t2m train` or upgrade t2m") from None
    return load_weights(directory / file, network)


def update_config(directory: Path, **sections: Any) -> dict[str, Any]:
    """Merge ``sections`` into ``config.json`` (created when missing) and write it atomically."""
    path = Path(directory) / CONFIG_NAME
    config = read_config(directory) if path.exists() else {"format": CHECKPOINT_FORMAT}
    config.update(sections)
    write_json_atomic(path, config)
    return config


def save_training_state(path: Path, modules: dict[str, nn.Module | torch.optim.Optimizer], extra: dict[str, Any]) -> None:
    """Everything a killed training run needs to resume: weights, optimiser moments, step and RNG,
    as safetensors tensors plus JSON metadata (no pickle), atomically."""
    from safetensors.torch import save

    tensors: dict[str, torch.Tensor] = {}
    scalars: dict[str, Any] = {}
    for prefix, module in modules.items():
        if isinstance(module, torch.optim.Optimizer):
            state = module.state_dict()
            for index, values in state["state"].items():
                for key, value in values.items():
                    if torch.is_tensor(value):
                        tensors[f"{prefix}/state/{index}/{key}"] = value.detach().contiguous().clone()
                    else:
                        scalars[f"{prefix}/state/{index}/{key}"] = value
            scalars[f"{prefix}/param_groups"] = state["param_groups"]
        else:
            for name, tensor in module.state_dict().items():
                tensors[f"{prefix}/{name}"] = tensor.detach().contiguous().clone()
    tensors["rng/torch"] = torch.get_rng_state()
    metadata = {"scalars": json.dumps(scalars), "extra": json.dumps(extra)}
    write_bytes_atomic(path, save(tensors, metadata=metadata))


def load_training_state(path: Path, modules: dict[str, nn.Module | torch.optim.Optimizer]) -> dict[str, Any]:
    """Restore what :func:`save_training_state` wrote into ``modules``; returns its ``extra``.

    Raises:
        CheckpointError: unreadable or mismatched file.
    """
    from safetensors import safe_open

    try:
        with safe_open(str(path), framework="pt") as handle:
            metadata = handle.metadata() or {}
            tensors = {key: handle.get_tensor(key) for key in handle.keys()}  # noqa: SIM118
        scalars, extra = json.loads(metadata["scalars"]), json.loads(metadata["extra"])
    except Exception as error:
        raise CheckpointError(f"training state {path} is unreadable: {error}", "delete it to start the run afresh") from None
    try:
        for prefix, module in modules.items():
            if isinstance(module, torch.optim.Optimizer):
                state: dict[int, dict[str, Any]] = {}
                for key, value in [*tensors.items(), *scalars.items()]:
                    parts = key.split("/")
                    if parts[0] == prefix and parts[1] == "state":
                        state.setdefault(int(parts[2]), {})[parts[3]] = value
                module.load_state_dict({"state": state, "param_groups": scalars[f"{prefix}/param_groups"]})
            else:
                own = {key[len(prefix) + 1 :]: value for key, value in tensors.items() if key.startswith(prefix + "/")}
                module.load_state_dict(own, strict=True)
        torch.set_rng_state(tensors["rng/torch"])
    except (KeyError, RuntimeError, ValueError) as error:
        raise CheckpointError(f"training state {path} does not fit this run: {error}", "delete it to start the run afresh") from None
    return extra
