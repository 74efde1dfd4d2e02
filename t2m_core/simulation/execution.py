"""One primitive execution on any backend, as the domain's execution contract describes
(docs/guide/primitives.md): precheck, the motion steps in order with the disturbance test and the
step's own check after each, then the post-conditions."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from t2m_core.domain.observation import encode_observation
from t2m_core.domain.primitives import Outcome, StepContext, first_disturbed, get_primitive
from t2m_core.protocols import Contact, PrimitiveResult
from t2m_core.simulation.backend import PhysicsBackend
from t2m_core.simulation.motion import MotionExecutor


def checked_action(action: np.ndarray, dim: int) -> np.ndarray:
    """``action`` as a ``(dim,) float64`` array in ``[-1, 1]``; ``ValueError`` naming the problem otherwise."""
    array = np.asarray(action, dtype=np.float64)
    if array.shape != (dim,):
        raise ValueError(f"action must have shape ({dim},), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"action must be finite, got {array}")
    if np.any(np.abs(array) > 1.0 + 1e-6):
        raise ValueError(f"action must be normalised to [-1, 1], got {array}")
    return np.clip(array, -1.0, 1.0)


def execute_primitive(
    backend: PhysicsBackend, motions: MotionExecutor, primitive: str, arguments: Sequence[str], action: np.ndarray
) -> PrimitiveResult:
    """Run ``primitive`` on the named objects with a normalised ``(4,)`` action in ``[-1, 1]``.

    The backend is canonicalised first (:meth:`PhysicsBackend.canonicalize`), so the result does not
    depend on whether the scene was just restored. The result carries no frames.

    Raises:
        KeyError: unknown primitive. ValueError: bad arguments or action.
    """
    spec = get_primitive(primitive)
    action = checked_action(action, spec.action_dim)
    start = backend.geometric_state()
    arguments = spec.check_arguments(start, arguments)
    backend.canonicalize()
    motions.begin_primitive()
    contacts: list[Contact] = []
    reason = spec.precheck(start, arguments, action)
    if reason is None:
        for step in spec.motion(start, arguments, action):
            report = motions.run(step)
            contacts.extend(report.contacts)
            reason = report.failure
            if reason is None:
                now = backend.geometric_state()
                reason = first_disturbed(start, now, step.disturbance_objects)
                if reason is None and step.check is not None:
                    reason = step.check(StepContext(start, now, arguments, backend.distance))
            if reason is not None:
                break
    end = backend.geometric_state()
    outcome = Outcome.failed(reason) if reason is not None else spec.outcome(start, end, arguments)
    return PrimitiveResult(
        success=outcome.success,
        truncated=outcome.truncated,
        failure=outcome.failure,
        state=end,
        observation=encode_observation(end, tuple(end.objects)),
        contacts=tuple(contacts),
    )
