"""The observation and state vectors the learned models see (docs/guide/world.md#observation-encoding, docs/guide/skills.md#state-encodings).

- raw observation: ``(8, 12) float32``; row 0 the end effector (pose relative to home), rows 1..N
  the present objects in task order, the rest zeros;
- skill state: the rows reordered argument-first, optionally shuffled in the shuffle range,
  normalised to [−0.5, 0.5] and flattened to ``(96,)``;
- dynamics state: the same without shuffling, and its inverse mapping for predictions.

Batched functions take ``(..., 8, 12)`` and return ``(..., 96)`` (or back).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from t2m_core.domain.geometry import axis_angle_to_quat, quat_to_axis_angle
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.state import GeometricState, ObjectPose

OBSERVATION_ROWS = 8
"""Rows of the raw observation: the end effector plus at most 7 objects."""
FEATURES = 12
"""Features per row."""
MAX_OBJECTS = OBSERVATION_ROWS - 1
"""Objects that fit in an observation."""
STATE_DIM = OBSERVATION_ROWS * FEATURES
"""96: the flattened skill / dynamics state."""
STATIC_FEATURES = slice(6, 12)
"""Shape features (box size, hook dimensions): constant for a rigid object."""

FEATURE_LOW = np.array([-0.3, -0.5, -0.1, -np.pi, -np.pi, -np.pi, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0], dtype=np.float32)
"""``(12,)`` lower normalisation bound per feature: x, y, z (m), axis-angle (rad), box size
(m), head length, handle length (m), handle_y."""
FEATURE_HIGH = np.array([0.9, 0.5, 0.5, np.pi, np.pi, np.pi, 0.4, 0.4, 0.2, 0.3, 0.5, 1.0], dtype=np.float32)
"""``(12,)`` upper normalisation bound per feature."""


class ObservationError(ValueError):
    """An observation or object list that does not fit the 8 × 12 layout."""


# --------------------------------------------------------------------------------------------------
# Raw observation
# --------------------------------------------------------------------------------------------------


def encode_observation(state: GeometricState, object_names: Sequence[str] | None = None) -> np.ndarray:
    """``(8, 12) float32`` raw observation of ``state``.

    Args:
        state: poses; ``ee_quaternion`` is already relative to the home orientation.
        object_names: task order; defaults to ``state.object_names``. Absent objects get no row.

    Raises:
        ObservationError: more than 7 present objects.
    """
    names = present_objects(state, object_names)
    observation = np.zeros((OBSERVATION_ROWS, FEATURES), dtype=np.float32)
    observation[0, :3] = state.ee_position
    observation[0, 3:6] = quat_to_axis_angle(state.ee_quaternion)
    for row, name in enumerate(names, start=1):
        spec = object_spec(name)
        if spec.kind is ObjectKind.TABLE:
            continue  # identity pose, no shape features: an all-zero row (models depend on it)
        pose = state.objects[name]
        observation[row, :3] = pose.position
        observation[row, 3:6] = quat_to_axis_angle(pose.quaternion)
        observation[row, STATIC_FEATURES] = spec.shape_features()
    return observation


def present_objects(state: GeometricState, object_names: Sequence[str] | None = None) -> tuple[str, ...]:
    """The objects of ``object_names`` (default: the state's) that have a pose, in order; at most 7."""
    names = tuple(n for n in (object_names if object_names is not None else state.object_names) if n in state.objects)
    if len(names) > MAX_OBJECTS:
        raise ObservationError(f"{len(names)} objects present ({', '.join(names)}); an observation holds at most 7")
    return names


def decode_observation(observation: np.ndarray, object_names: Sequence[str]) -> GeometricState:
    """Inverse of :func:`encode_observation`: rows 1..N become the poses of ``object_names`` (the
    present objects in row order). The table gets the identity pose; ``held`` is unknown (``None``).

    Args:
        observation: ``(8, 12)`` raw observation (real or predicted).
        object_names: the present objects, in row order.

    Raises:
        ObservationError: wrong shape or more than 7 names.
    """
    obs = np.asarray(observation, dtype=np.float64)
    if obs.shape != (OBSERVATION_ROWS, FEATURES):
        raise ObservationError(f"expected an (8, 12) observation, got shape {obs.shape}")
    if len(object_names) > MAX_OBJECTS:
        raise ObservationError(f"{len(object_names)} object names; an observation holds at most 7")
    quats = axis_angle_to_quat(obs[:, 3:6])
    objects = {}
    for row, name in enumerate(object_names, start=1):
        if object_spec(name).kind is ObjectKind.TABLE:
            objects[name] = ObjectPose(np.zeros(3))
        else:
            objects[name] = ObjectPose(obs[row, :3], quats[row])
    return GeometricState(objects, ee_position=obs[0, :3].copy(), ee_quaternion=quats[0])


def normalize(observation: np.ndarray) -> np.ndarray:
    """Map every feature of ``(..., 12)`` rows to [−0.5, 0.5]: (v − mid)/(high − low). float32."""
    mid = 0.5 * (FEATURE_LOW + FEATURE_HIGH)
    return ((np.asarray(observation, dtype=np.float32) - mid) / (FEATURE_HIGH - FEATURE_LOW)).astype(np.float32)


def unnormalize(normalized: np.ndarray) -> np.ndarray:
    """Inverse of :func:`normalize`, ``(..., 12)`` float32."""
    mid = 0.5 * (FEATURE_LOW + FEATURE_HIGH)
    return (np.asarray(normalized, dtype=np.float32) * (FEATURE_HIGH - FEATURE_LOW) + mid).astype(np.float32)


# --------------------------------------------------------------------------------------------------
# Argument-first order
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RowOrder:
    """The row layout of one skill instance.

    Attributes:
        order: ``(8,) int64``; ``order[i]`` is the raw-observation row placed at position i: row 0,
            the argument rows in argument order, the other present rows, then the empty rows.
        shuffle_start: first position of the shuffle range (1 + number of arguments).
        shuffle_stop: end of the shuffle range (1 + number of present objects).
    """

    order: np.ndarray
    shuffle_start: int
    shuffle_stop: int

    @property
    def num_present(self) -> int:
        """Number of present objects (rows 1..N)."""
        return self.shuffle_stop - 1

    @property
    def inverse(self) -> np.ndarray:
        """``(8,) int64`` position of each raw row in the reordered layout."""
        return np.argsort(self.order)


def argument_first_order(object_names: Sequence[str], arguments: Sequence[str]) -> RowOrder:
    """The argument-first row order of a skill call in a scene.

    Args:
        object_names: the present objects in row order (rows 1..N).
        arguments: the skill's arguments, e.g. ``("red_box", "rack")``.

    Raises:
        ObservationError: an argument not among the objects, or more than 7 objects.
    """
    names = list(object_names)
    if len(names) > MAX_OBJECTS:
        raise ObservationError(f"{len(names)} objects; an observation holds at most 7")
    missing = [a for a in arguments if a not in names]
    if missing:
        raise ObservationError(f"argument(s) {', '.join(missing)} not among the scene objects {', '.join(names)}")
    argument_rows = [1 + names.index(a) for a in arguments]
    other_rows = [row for row in range(1, 1 + len(names)) if row not in argument_rows]
    empty_rows = list(range(1 + len(names), OBSERVATION_ROWS))
    order = np.array([0, *argument_rows, *other_rows, *empty_rows], dtype=np.int64)
    return RowOrder(order, 1 + len(arguments), 1 + len(names))


def _row_orders(row_order: RowOrder, batch_shape: tuple[int, ...], rng: np.random.Generator | None) -> np.ndarray:
    """``(*batch_shape, 8)`` per-sample orders, the shuffle range permuted per sample if ``rng``."""
    orders = np.broadcast_to(row_order.order, (*batch_shape, OBSERVATION_ROWS)).copy()
    start, stop = row_order.shuffle_start, row_order.shuffle_stop
    if rng is not None and stop - start > 1:
        keys = rng.random((*batch_shape, stop - start))
        orders[..., start:stop] = np.take_along_axis(orders[..., start:stop], np.argsort(keys, axis=-1), axis=-1)
    return orders


def _reorder(observation: np.ndarray, orders: np.ndarray) -> np.ndarray:
    return np.take_along_axis(observation, orders[..., None], axis=-2)


def skill_state(observation: np.ndarray, row_order: RowOrder, rng: np.random.Generator | None = None) -> np.ndarray:
    """Policy / Q-function input: ``(..., 8, 12)`` → ``(..., 96) float32``.

    The non-argument rows are shuffled (independently per sample) only when ``rng`` is given: during
    training. Planning passes no ``rng`` and gets the fixed task order
    (docs/guide/deviations.md#planning-time-row-order).
    """
    obs = _check_observation(observation)
    reordered = _reorder(obs, _row_orders(row_order, obs.shape[:-2], rng))
    return normalize(reordered).reshape(*obs.shape[:-2], STATE_DIM)


def reordered_rows(observation: np.ndarray, orders: np.ndarray) -> np.ndarray:
    """Normalised rows in per-sample orders: ``(N, 8, 12)`` observations and ``(N, 8)`` orders (as
    :attr:`RowOrder.order` gives them) → ``(N, 8, 12) float32``; flattening gives the unshuffled
    skill state of every sample (how a trainer encodes a dataset whose samples have different calls)."""
    obs = _check_observation(observation)
    return normalize(_reorder(obs, np.asarray(orders, dtype=np.int64)))


def dynamics_state(observation: np.ndarray, row_order: RowOrder) -> np.ndarray:
    """Dynamics input: argument-first, never shuffled, normalised. ``(..., 8, 12)`` →
    ``(..., 96) float32``."""
    return skill_state(observation, row_order, rng=None)


def decode_dynamics_prediction(prediction: np.ndarray, observation: np.ndarray, row_order: RowOrder) -> np.ndarray:
    """Map a dynamics prediction back to a raw observation (docs/guide/skills.md#state-encodings).

    Clamp to [−0.5, 0.5], un-normalise, scatter the rows back to their raw positions, copy the static
    features (indices 6-11) from the input (objects are rigid) and zero the rows beyond the present
    objects.

    Args:
        prediction: ``(..., 96)`` predicted dynamics state.
        observation: ``(..., 8, 12)`` the raw observation the prediction started from.
        row_order: the skill's row order used to encode it.

    Returns:
        ``(..., 8, 12) float32`` predicted raw observation.
    """
    obs = _check_observation(observation)
    pred = np.asarray(prediction, dtype=np.float32)
    if pred.shape[-1] != STATE_DIM:
        raise ObservationError(f"expected (..., 96) predictions, got shape {pred.shape}")
    rows = unnormalize(np.clip(pred, -0.5, 0.5).reshape(*pred.shape[:-1], OBSERVATION_ROWS, FEATURES))
    restored = rows[..., row_order.inverse, :]
    restored[..., STATIC_FEATURES] = obs[..., STATIC_FEATURES]
    restored[..., 1 + row_order.num_present :, :] = 0.0
    return restored


def _check_observation(observation: np.ndarray) -> np.ndarray:
    obs = np.asarray(observation, dtype=np.float32)
    if obs.shape[-2:] != (OBSERVATION_ROWS, FEATURES):
        raise ObservationError(f"expected (..., 8, 12) observations, got shape {obs.shape}")
    return obs
