"""The scene file format: what a person measures with a tape and a protractor.

Frame: the robot base on the table top; +x away from the robot, +y to its left, +z up (the TableEnv
world frame). Example (``scenes/example.yaml``)::

    units: {length: cm, angle: deg}   # optional; default metres and radians
    objects:
      - {name: rack, position: [44, -33]}              # z omitted: standing on the table
      - {name: red_box, position: [50, 10], yaw: 30}
      - {name: hook, position: [35, 20, 2], quaternion: [0, 0, 0, 1]}
      - {name: blue_box, position: [60, 5], size: [5, 5, 10.6]}   # measured size, checked

Poses are given for the object-frame origin: the centre of the bounding box, except the rack, whose
origin is its top plate (TableEnv convention, ``t2m_core.domain.objects``).
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

LENGTH_TO_METRES: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}
ANGLE_TO_RADIANS: dict[str, float] = {"rad": 1.0, "deg": 3.141592653589793 / 180.0}


class Units(BaseModel):
    """Units of every length and angle in the file."""

    model_config = ConfigDict(extra="forbid")

    length: Literal["m", "cm", "mm"] = "m"
    angle: Literal["rad", "deg"] = "rad"


class MeasuredObject(BaseModel):
    """One object as measured.

    Attributes:
        name: a TableEnv object (``rack``, ``hook``, ``red_box``, ``blue_box``, ``yellow_box``, ``cyan_box``).
        position: ``[x, y]`` or ``[x, y, z]`` of the object-frame origin; without z the object stands
            upright on the table.
        yaw: rotation about +z (file's angle unit); or give ``quaternion`` instead.
        quaternion: ``[x, y, z, w]`` orientation; normalised on reading.
        size: measured ``[sx, sy, sz]`` bounding box (file's length unit); checked against the object.
    """

    model_config = ConfigDict(extra="forbid")

    name: str = Field(min_length=1)
    position: list[float] = Field(min_length=2, max_length=3)
    yaw: float | None = None
    quaternion: tuple[float, float, float, float] | None = None
    size: tuple[float, float, float] | None = None

    @model_validator(mode="after")
    def _one_orientation(self) -> MeasuredObject:
        if self.yaw is not None and self.quaternion is not None:
            raise ValueError("give yaw or quaternion, not both")
        if self.quaternion is not None and sum(v * v for v in self.quaternion) < 1e-12:
            raise ValueError("quaternion must not be all zeros")
        if self.size is not None and min(self.size) <= 0:
            raise ValueError("size must be positive in every axis")
        return self


class MeasuredEndEffector(BaseModel):
    """The gripper's operational point, if it is not at the home pose."""

    model_config = ConfigDict(extra="forbid")

    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)


class MeasuredScene(BaseModel):
    """A whole scene file."""

    model_config = ConfigDict(extra="forbid")

    units: Units = Field(default_factory=Units)
    objects: list[MeasuredObject] = Field(min_length=1)
    end_effector: MeasuredEndEffector | None = None
    held: str | None = Field(None, description="Name of the object in the gripper, if any")

    @model_validator(mode="after")
    def _unique_names(self) -> MeasuredScene:
        names = [measured.name for measured in self.objects]
        repeated = sorted({name for name in names if names.count(name) > 1})
        if repeated:
            raise ValueError(f"objects listed more than once: {', '.join(repeated)}")
        if self.held is not None and self.held not in names:
            raise ValueError(f"held object {self.held!r} is not among the objects")
        return self
