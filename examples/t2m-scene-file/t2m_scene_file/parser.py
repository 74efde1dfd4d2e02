"""The ``scene-file`` parser: a hand-measured scene file -> :class:`~t2m_core.domain.state.GeometricState`."""

from __future__ import annotations

import dataclasses
import difflib
from pathlib import Path

import numpy as np
import yaml
from pydantic import ValidationError

from t2m_core.domain.geometry import is_upright, quat_normalize, yaw_to_quat
from t2m_core.domain.objects import OBJECTS, ObjectKind
from t2m_core.domain.state import GeometricState, ObjectPose
from t2m_core.errors import T2MError
from t2m_core.protocols import SceneObservation
from t2m_scene_file.hooks import SceneFileOptions
from t2m_scene_file.scene import ANGLE_TO_RADIANS, LENGTH_TO_METRES, MeasuredObject, MeasuredScene


class SceneFileError(T2MError):
    """The scene file is missing, malformed, or does not describe the task's objects."""


def read_scene(path: Path) -> MeasuredScene:
    """Read and validate a scene file (YAML or JSON).

    Raises:
        SceneFileError: naming the file and, for invalid content, each bad key's path.
    """
    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except OSError as error:
        raise SceneFileError(
            f"cannot read scene file {path}: {error.strerror}", hint="check scene_parser.options.path"
        ) from None
    except yaml.YAMLError as error:
        raise SceneFileError(f"scene file {path} is not valid YAML/JSON: {error}", hint="fix the syntax") from None
    try:
        return MeasuredScene.model_validate(data)
    except ValidationError as error:
        problems = "; ".join(
            f"{'.'.join(str(part) for part in issue['loc']) or '(file)'}: {issue['msg']}" for issue in error.errors()
        )
        raise SceneFileError(
            f"scene file {path} is invalid: {problems}", hint="see scenes/example.yaml of t2m-scene-file"
        ) from None


def object_pose(measured: MeasuredObject, scene: MeasuredScene, size_tolerance: float) -> ObjectPose:
    """The world pose of one measured object, in metres and an ``(x, y, z, w)`` quaternion.

    Raises:
        SceneFileError: unknown object, a size that does not match the object, or a tilted object
            without a measured height.
    """
    if measured.name not in OBJECTS or OBJECTS[measured.name].kind is ObjectKind.TABLE:
        movable = [name for name, spec in OBJECTS.items() if spec.kind is not ObjectKind.TABLE]
        close = difflib.get_close_matches(measured.name, movable, n=1)
        suggestion = f"did you mean {close[0]!r}? " if close else ""
        raise SceneFileError(
            f"unknown object {measured.name!r} in the scene file (the table is the frame's origin: leave it out)",
            hint=f"{suggestion}objects t2m knows: {', '.join(movable)}",
        )
    spec = OBJECTS[measured.name]
    metres = LENGTH_TO_METRES[scene.units.length]
    if measured.quaternion is not None:
        quaternion = quat_normalize(np.array(measured.quaternion, dtype=np.float64))
    else:
        quaternion = yaw_to_quat((measured.yaw or 0.0) * ANGLE_TO_RADIANS[scene.units.angle])
    if measured.size is not None:
        size = np.array(measured.size, dtype=np.float64) * metres
        deviation = float(np.max(np.abs(size - np.array(spec.size))))
        if deviation > size_tolerance:
            raise SceneFileError(
                f"{measured.name}: measured size {np.round(size, 3).tolist()} m differs from the TableEnv "
                f"{measured.name} {list(spec.size)} m by {deviation:.3f} m (tolerance {size_tolerance} m)",
                hint="t2m's learned skills know only the TableEnv objects: measure again, use the matching "
                "object name, or raise scene_parser.options.size_tolerance",
            )
        spec = dataclasses.replace(spec, size=tuple(float(v) for v in size))
    position = np.array(measured.position, dtype=np.float64) * metres
    if position.shape == (2,):
        if not is_upright(quaternion):
            raise SceneFileError(
                f"{measured.name}: give its height (position [x, y, z]): it is tilted, so it does not stand on the table",
                hint="add z, the height of its origin above the table top",
            )
        lowest_point = spec.local_bounds()[0][2]  # object frame; upright, so it maps straight to world z
        position = np.append(position, -lowest_point)
    return ObjectPose(position, quaternion)


class SceneFileParser:
    """Reads the scene file once (so a bad file fails when the parser is built) and answers every
    :meth:`parse` with its poses, in the order of ``observation.object_names``."""

    def __init__(self, options: SceneFileOptions) -> None:
        self.options = options
        self.scene = read_scene(options.path)
        self.poses = {
            measured.name: object_pose(measured, self.scene, options.size_tolerance) for measured in self.scene.objects
        }

    def parse(self, observation: SceneObservation) -> GeometricState:
        """The measured state of ``observation.object_names`` (the table at the origin).

        Raises:
            SceneFileError: the file lacks an object the task needs, or lists one the task does not
                know (it would be an obstacle the planner cannot see).
        """
        wanted = tuple(observation.object_names) or ("table", *self.poses)
        missing = [name for name in wanted if name != "table" and name not in self.poses]
        unexpected = [name for name in self.poses if name not in wanted]
        if missing or unexpected:
            details = "; ".join(
                part
                for part in (
                    f"missing {', '.join(missing)}" if missing else "",
                    f"not in the task {', '.join(unexpected)}" if unexpected else "",
                )
                if part
            )
            raise SceneFileError(
                f"scene file {self.options.path} does not match the task's objects ({', '.join(wanted)}): {details}",
                hint="measure the missing objects, and take away (and delete from the file) objects the task does not use",
            )
        objects = {name: ObjectPose(np.zeros(3)) if name == "table" else self.poses[name] for name in wanted}
        effector = self.scene.end_effector
        if effector is None:
            return GeometricState(objects=objects, held=self.scene.held)
        metres = LENGTH_TO_METRES[self.scene.units.length]
        return GeometricState(
            objects=objects,
            ee_position=np.array(effector.position, dtype=np.float64) * metres,
            ee_quaternion=quat_normalize(np.array(effector.quaternion, dtype=np.float64)),
            held=self.scene.held,
        )
