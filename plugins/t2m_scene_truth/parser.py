"""The ``ground-truth`` scene parser: reads the simulator's geometric state from the observation.

This is the perception the Text2Motion paper evaluates with: object poses are exact, so planning
results measure the planners and not a vision pipeline.
"""

from __future__ import annotations

from pydantic import BaseModel

from t2m_core.domain.state import GeometricState
from t2m_core.errors import T2MError
from t2m_core.protocols import SceneObservation


class GroundTruthSceneParser:
    """Returns ``observation.ground_truth``, objects in ``observation.object_names`` order."""

    def __init__(self, options: BaseModel | None = None) -> None:
        del options  # takes none (NoOptions)

    def parse(self, observation: SceneObservation) -> GeometricState:
        """The ground-truth state, restricted to and ordered as ``observation.object_names``.

        Raises:
            T2MError: the observation carries no ground truth (not from a simulator), or the ground
                truth lacks one of the requested objects.
        """
        truth = observation.ground_truth
        if truth is None:
            raise T2MError(
                "the ground-truth scene parser needs the simulator's state, but the observation has none",
                hint="choose a scene parser that reads sensors or a file, e.g. "
                "--set scene_parser.name=scene-file (pip install t2m-scene-file)",
            )
        names = tuple(observation.object_names) or truth.object_names
        missing = [name for name in names if name not in truth.objects]
        if missing:
            raise T2MError(
                f"the ground-truth state has no object(s) {', '.join(missing)}; it has {', '.join(truth.object_names)}",
                hint="the task's object list and the simulated scene disagree: reset the simulator to this task",
            )
        if names == truth.object_names:
            return truth
        return GeometricState(
            objects={name: truth.objects[name] for name in names},
            ee_position=truth.ee_position,
            ee_quaternion=truth.ee_quaternion,
            held=truth.held,
        )
