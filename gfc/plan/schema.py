"""The JSON plan a user sends: scene, skeleton, constraints, goal and sampling options.

Only *shape* is checked here (types, finite numbers, unit quaternions, bounded sizes, known
vocabulary). Whether the skeleton makes sense (who holds what, which steps exist) is the
compiler's job (``gfc.plan.compiler``), which reports every problem with its location.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    StringConstraints,
    model_validator,
)

# Limits that keep one request bounded in memory and time.
MAX_ROBOTS = 4
MAX_OBJECTS = 64
MAX_STEPS = 64
MAX_CONSTRAINTS = 128
MAX_CANDIDATES = 256
MAX_SAMPLING_STEPS = 500
MAX_COORDINATE = 10.0  # metres from the world origin
QUATERNION_TOLERANCE = 1e-3

Name = Annotated[
    str,
    StringConstraints(min_length=1, max_length=64, pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$"),
]
Finite = Annotated[float, Field(allow_inf_nan=False)]
Coordinate = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_COORDINATE, le=MAX_COORDINATE)]


def _unit_quaternion(pose: list[float]) -> list[float]:
    norm = math.sqrt(sum(q * q for q in pose[3:7]))
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise ValueError(
            f"quaternion [qx, qy, qz, qw] = {pose[3:7]} has norm {norm:.4f}; it must be a unit "
            f"quaternion (norm 1 within {QUATERNION_TOLERANCE})"
        )
    return pose


Vec3 = Annotated[list[Coordinate], Field(min_length=3, max_length=3)]
Pose = Annotated[
    list[Finite],
    Field(min_length=7, max_length=7, description="[x, y, z, qx, qy, qz, qw]"),
    AfterValidator(_unit_quaternion),
]


def _bounded_position(pose: list[float]) -> list[float]:
    for axis, value in zip("xyz", pose[:3], strict=True):
        if abs(value) > MAX_COORDINATE:
            raise ValueError(f"{axis} = {value} m is more than {MAX_COORDINATE} m from the origin")
    return pose


ScenePose = Annotated[Pose, AfterValidator(_bounded_position)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class RobotSpec(_Strict):
    name: Name
    base: Vec3 = Field(description="base position in the world [x, y, z]")
    yaw: Finite = Field(0.0, description="base heading about world z, radians")
    ee_pose: ScenePose | None = Field(
        None, description="initial end-effector pose in the world; default: the home pose"
    )
    gripper: Annotated[float, Field(ge=0.0, le=0.08)] = Field(0.08, description="opening, m")


class ObjectSpec(_Strict):
    name: Name
    kind: Name
    pose: ScenePose
    fixed: bool = False


class Scene(_Strict):
    robots: list[RobotSpec] = Field(min_length=1, max_length=MAX_ROBOTS)
    objects: list[ObjectSpec] = Field(default_factory=list, max_length=MAX_OBJECTS)


class Step(_Strict):
    skill: Name
    robot: Name
    object: Name | None = None
    target: Name | None = None
    from_: Name | None = Field(None, alias="from")
    group: Name | None = Field(None, description="steps with the same group run at the same time")
    model: Annotated[str, StringConstraints(min_length=1, max_length=128)] | None = Field(
        None, description="skill model as NAME[@VERSION|@ALIAS]; default SKILL.OBJECT_KIND"
    )


StepRef = Annotated[int, Field(ge=0)] | Name
"""A point in the plan: a step index (the state right after it), a group name (right after the
group), ``"start"`` (the initial scene) or ``"end"`` (after the last step)."""


class _SpatialBase(_Strict):
    at: StepRef | list[StepRef] = Field("end", description="state(s) the factor applies to")
    weight: Annotated[float, Field(gt=0.0, le=1e8, allow_inf_nan=False)] = 1.0

    def refs(self) -> list[int | str]:
        return list(self.at) if isinstance(self.at, list) else [self.at]


class Inside(_SpatialBase):
    """The object's bottom centre lies inside the target container's open region."""

    type: Literal["inside"]
    object: Name
    target: Name
    margin: Annotated[float, Field(ge=0.0, le=1.0)] = 0.01


class Aligned(_SpatialBase):
    """A frame of the object lies over a frame of the target (xy), optionally at a height; with
    ``offset``, that far from it horizontally (on a circle around it, in any direction)."""

    type: Literal["aligned"]
    object: Name
    target: Name
    frame: Name | None = None
    target_frame: Name | None = None
    height: Annotated[float, Field(ge=-1.0, le=1.0, allow_inf_nan=False)] | None = None
    offset: Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)] = Field(
        0.0, description="horizontal distance between the two frame points, m (0: right over it)"
    )
    tolerance: Annotated[float, Field(gt=0.0, le=1.0)] = 0.01


class FixedTransform(_SpatialBase):
    """The pose of ``target`` relative to ``object`` is the same at every listed state, or equal
    to ``transform`` when given (entities may be robots: their end effectors)."""

    type: Literal["fixed_transform"]
    object: Name
    target: Name
    transform: Pose | None = None
    tolerance: Annotated[float, Field(gt=0.0, le=1.0)] = 0.01


class Yaw(_SpatialBase):
    """The object's heading about world z equals ``yaw_deg``."""

    type: Literal["yaw"]
    object: Name
    yaw_deg: Annotated[float, Field(ge=-360.0, le=360.0, allow_inf_nan=False)]
    tolerance_deg: Annotated[float, Field(gt=0.0, le=180.0)] = 5.0


class Near(_SpatialBase):
    """The two entities' origins are at most ``distance`` apart."""

    type: Literal["near"]
    object: Name
    target: Name
    distance: Annotated[float, Field(gt=0.0, le=5.0)]


class Far(_SpatialBase):
    """The two entities' origins are at least ``distance`` apart."""

    type: Literal["far"]
    object: Name
    target: Name
    distance: Annotated[float, Field(gt=0.0, le=5.0)]


class Apart(_SpatialBase):
    """The two objects' footprints (their boxes seen from above, turned as the objects are) do
    not overlap and keep ``clearance`` between them: packing without collisions. Unlike ``far``
    on their centres, it holds for any yaw (two 5 cm blocks 5.5 cm apart overlap when turned)."""

    type: Literal["apart"]
    object: Name
    target: Name
    clearance: Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)] = 0.005


SpatialFactorSpec = Annotated[
    Inside | Aligned | FixedTransform | Yaw | Near | Far | Apart, Field(discriminator="type")
]
SPATIAL_TYPES = ("inside", "aligned", "fixed_transform", "yaw", "near", "far", "apart")


class Options(_Strict):
    candidates: Annotated[int, Field(ge=1, le=MAX_CANDIDATES)] = 10
    top_k: Annotated[int, Field(ge=1, le=MAX_CANDIDATES)] = 5
    steps: Annotated[int, Field(ge=1, le=MAX_SAMPLING_STEPS)] = 50
    seed: Annotated[int, Field(ge=0, le=2**63 - 1)] = 0
    sampler: Literal["euler", "heun"] = "euler"
    compensation: Literal["marginal", "mean", "none"] = Field(
        "marginal", description="how nodes shared by two skills are counted once (see docs/adr/0001)"
    )
    corrector_steps: Annotated[int, Field(ge=0, le=20)] = Field(
        0, description="Langevin corrector steps per sampling step (slower, closer to the product)"
    )
    kinematics: bool = Field(
        False,
        description="add the skills' kinematic links (a carried object stays put in the hand, a "
        "placed object rests at the place action) as implied factors; off by default: on the "
        "benchmark they lowered success (docs/adr/0002)",
    )

    @model_validator(mode="after")
    def _top_k_within_candidates(self) -> Options:
        if self.top_k > self.candidates:
            raise ValueError(f"top_k ({self.top_k}) exceeds candidates ({self.candidates})")
        return self


class PlanRequest(_Strict):
    scene: Scene
    skeleton: list[Step] = Field(min_length=1, max_length=MAX_STEPS)
    constraints: list[SpatialFactorSpec] = Field(default_factory=list, max_length=MAX_CONSTRAINTS)
    goal: list[SpatialFactorSpec] = Field(default_factory=list, max_length=MAX_CONSTRAINTS)
    options: Options = Field(default_factory=Options)

    def to_json_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json", by_alias=True, exclude_none=True)
