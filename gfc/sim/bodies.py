"""The object library: every object kind of ``gfc.kinds`` built from PyBullet primitives.

Each builder lays out boxes (and the odd cylinder) in the *object frame*, whose origin is the
centre of the object's bottom face. PyBullet reports a body's pose at its centre of mass, so
every body remembers ``object_from_com`` and ``gfc.sim.state`` converts. Masses are those of
real objects of that size (a wooden mallet, a ceramic mug, a steel pot); frictions are high on
what the fingers hold and on what must not slide on the table, and are listed in docs/sim.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pybullet as pb

from gfc.geometry import FloatArray, matrix_to_quat
from gfc.kinds import object_kind

Rgba = tuple[float, float, float, float]

WOOD: Rgba = (0.72, 0.52, 0.30, 1.0)
STEEL: Rgba = (0.55, 0.57, 0.60, 1.0)
CARDBOARD: Rgba = (0.80, 0.68, 0.48, 1.0)
PINK: Rgba = (0.93, 0.45, 0.62, 1.0)
GREEN: Rgba = (0.35, 0.72, 0.40, 1.0)
RED: Rgba = (0.85, 0.20, 0.18, 1.0)
BLUE: Rgba = (0.25, 0.42, 0.85, 1.0)
GREY: Rgba = (0.40, 0.40, 0.42, 1.0)
TABLE_TOP_Z = 0.625
TABLE_HALF_EXTENTS = (0.75, 1.0, 0.025)  # x from -0.45 to 1.05, y from -1 to 1
TABLE_CENTRE_XY = (0.30, 0.0)
BEAD_RADIUS = 0.009
BEAD_MASS = 0.004


@dataclass(frozen=True)
class Box:
    """One primitive: centre and half sizes in the object frame, optional yaw about z.

    ``cylinder=True`` makes an upright cylinder of radius ``half[0]`` and height ``2 * half[2]``
    (round floors, so that nothing rests on corners outside a round wall).
    """

    centre: tuple[float, float, float]
    half: tuple[float, float, float]
    rgba: Rgba
    yaw: float = 0.0
    cylinder: bool = False


@dataclass(frozen=True)
class Recipe:
    """How to build one kind: its primitives, total mass, friction and where its mass sits."""

    parts: tuple[Box, ...]
    mass: float
    lateral_friction: float
    com: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0))
    spinning_friction: float = 0.001
    rolling_friction: float = 0.0001


@dataclass(frozen=True)
class BuiltBody:
    body: int
    object_from_com: FloatArray  # 4x4: the body's PyBullet (centre of mass) frame in the object frame


def _ring(
    radius: float, height: float, thickness: float, rgba: Rgba, z0: float, segments: int = 12
) -> list[Box]:
    """A cylindrical wall of ``segments`` boxes: enough to hold beads and look round."""
    side = 2 * (radius + thickness / 2) * math.tan(math.pi / segments) + 0.002
    parts = []
    for i in range(segments):
        angle = 2 * math.pi * i / segments
        r = radius + thickness / 2
        parts.append(
            Box(
                (r * math.cos(angle), r * math.sin(angle), z0 + height / 2),
                (thickness / 2, side / 2, height / 2),
                rgba,
                yaw=angle,
            )
        )
    return parts


def _hammer() -> Recipe:
    k = object_kind("hammer")
    hx, hy, hz = k.half_extents
    head_half = (0.025, hy, hz)
    head_x = hx - head_half[0]
    handle_half = (hx - head_half[0], 0.0125, 0.0125)
    handle = Box((-hx + handle_half[0], 0.0, handle_half[2]), handle_half, WOOD)
    head = Box((head_x, 0.0, hz), head_half, STEEL)
    # Ash handle (~0.06 kg) and a steel head (~0.3 kg): the centre of mass lies near the head,
    # which is what makes a grasp near the head easy to hand over and one near the end a lever.
    m_handle, m_head = 0.06, 0.30
    com_x = (m_handle * handle.centre[0] + m_head * head.centre[0]) / (m_handle + m_head)
    return Recipe((handle, head), m_handle + m_head, 1.0, com=(com_x, 0.0, hz * 0.9))


def _nail() -> Recipe:
    hx, hy, hz = object_kind("nail").half_extents
    shaft = Box((0.0, 0.0, hz), (hx, hy, hz), STEEL)
    return Recipe((shaft,), 0.05, 0.9, com=(0.0, 0.0, hz))


def _solid(kind: str, rgba: Rgba, mass: float) -> Recipe:
    hx, hy, hz = object_kind(kind).half_extents
    return Recipe((Box((0.0, 0.0, hz), (hx, hy, hz), rgba),), mass, 0.9, com=(0.0, 0.0, hz))


def _lid() -> Recipe:
    hx, hy, hz = object_kind("lid").half_extents
    plate_half_z = 0.005
    plate = Box((0.0, 0.0, plate_half_z), (hx, hy, plate_half_z), CARDBOARD)
    knob_top = 2 * hz
    knob_half = (0.015, 0.015, (knob_top - 2 * plate_half_z) / 2)
    knob = Box((0.0, 0.0, 2 * plate_half_z + knob_half[2]), knob_half, WOOD)
    return Recipe((plate, knob), 0.15, 0.8, com=(0.0, 0.0, plate_half_z * 1.5))


def _open_box() -> Recipe:
    k = object_kind("box")
    hx, hy, hz = k.half_extents
    assert k.inner_half_extents is not None
    ix, iy, _ = k.inner_half_extents
    floor_half_z = 0.005
    wall_x, wall_y = hx - ix, hy - iy
    parts = [
        Box((0.0, 0.0, floor_half_z), (hx, hy, floor_half_z), CARDBOARD),
        Box((hx - wall_x / 2, 0.0, hz), (wall_x / 2, hy, hz), CARDBOARD),
        Box((-hx + wall_x / 2, 0.0, hz), (wall_x / 2, hy, hz), CARDBOARD),
        Box((0.0, hy - wall_y / 2, hz), (ix, wall_y / 2, hz), CARDBOARD),
        Box((0.0, -hy + wall_y / 2, hz), (ix, wall_y / 2, hz), CARDBOARD),
    ]
    return Recipe(tuple(parts), 0.4, 0.8, com=(0.0, 0.0, hz * 0.6))


def _vessel(kind: str, rgba: Rgba, mass: float, handle: bool) -> Recipe:
    k = object_kind(kind)
    hx, _, hz = k.half_extents
    assert k.inner_half_extents is not None
    inner = k.inner_half_extents[0]
    floor_half_z = 0.005
    parts = [Box((0.0, 0.0, floor_half_z), (hx, hx, floor_half_z), rgba, cylinder=True)]
    parts += _ring(inner, 2 * hz - 2 * floor_half_z, hx - inner, rgba, z0=2 * floor_half_z)
    if handle:
        # A loop handle at -x, as on a real mug: two stubs and a grip bar.
        parts += [
            Box((-hx - 0.012, 0.0, hz * 1.5), (0.012, 0.006, 0.005), rgba),
            Box((-hx - 0.012, 0.0, hz * 0.5), (0.012, 0.006, 0.005), rgba),
            Box((-hx - 0.022, 0.0, hz), (0.004, 0.006, hz * 0.5 + 0.005), rgba),
        ]
    return Recipe(tuple(parts), mass, 1.0, com=(0.0, 0.0, hz * 0.6))


def _pot() -> Recipe:
    k = object_kind("pot")
    hx, _hy, hz = k.half_extents
    assert k.inner_half_extents is not None
    inner = k.inner_half_extents[0]
    floor_half_z = 0.006
    parts = [Box((0.0, 0.0, floor_half_z), (hx, hx, floor_half_z), STEEL, cylinder=True)]
    parts += _ring(inner, 2 * hz - 2 * floor_half_z, hx - inner, STEEL, z0=2 * floor_half_z)
    # Handles: a bar along x just below the rim at y = +/-0.185 (the kind's named frames), joined
    # to the wall by a bracket. The grip is 2 cm wide so that the fingers close across it.
    for side, frame in ((1.0, "handle_left"), (-1.0, "handle_right")):
        fx, fy, fz = object_kind("pot").frames[frame][:3]
        parts.append(Box((fx, fy, fz), (0.045, 0.01, 0.01), GREY))
        bracket_y = (hx + abs(fy) - 0.01) / 2
        bracket_half_y = (abs(fy) - 0.01 - hx) / 2 + 0.005
        parts.append(Box((0.0, side * bracket_y, fz), (0.01, bracket_half_y, 0.008), GREY))
    return Recipe(tuple(parts), 1.2, 1.0, com=(0.0, 0.0, hz * 0.5))


def _hook() -> Recipe:
    hx, hy, hz = object_kind("hook").half_extents
    shaft = Box((0.0, -hy + 0.015, hz), (hx, 0.015, hz), BLUE)
    tip = Box((hx - 0.015, 0.015, hz), (0.015, hy - 0.015, hz), BLUE)
    return Recipe((shaft, tip), 0.2, 0.8, com=(0.0, -0.02, hz))


def _rack() -> Recipe:
    hx, hy, hz = object_kind("rack").half_extents
    bar_half_z = 0.01
    parts = [Box((0.0, 0.0, 2 * hz - bar_half_z), (hx, hy, bar_half_z), GREY)]
    for side in (1.0, -1.0):
        parts.append(Box((0.0, side * (hy - 0.01), hz - bar_half_z), (0.01, 0.01, hz - bar_half_z), GREY))
    return Recipe(tuple(parts), 2.0, 0.8, com=(0.0, 0.0, hz))


RECIPES: dict[str, Callable[[], Recipe]] = {
    "hammer": _hammer,
    "nail": _nail,
    "cube": lambda: _solid("cube", RED, 0.1),
    "block": lambda: _solid("block", BLUE, 0.15),
    "lid": _lid,
    "box": _open_box,
    "mug": lambda: _vessel("mug", PINK, 0.25, handle=True),
    "cup": lambda: _vessel("cup", GREEN, 0.2, handle=False),
    "pot": _pot,
    "hook": _hook,
    "rack": _rack,
}


def recipe_for(kind: str) -> Recipe:
    try:
        return RECIPES[kind]()
    except KeyError:
        raise KeyError(f"the simulator cannot build object kind {kind!r}") from None


def _yaw_quat(yaw: float) -> list[float]:
    return [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]


def build_body(client: int, kind: str, world_from_object: FloatArray, fixed: bool) -> BuiltBody:
    """Create one object so that its object frame sits at ``world_from_object`` (scene building)."""
    recipe = recipe_for(kind)
    com = np.asarray(recipe.com)
    # Shapes are given relative to the centre-of-mass frame, which PyBullet places at the base.
    positions = [list(np.asarray(p.centre) - com) for p in recipe.parts]
    orientations = [_yaw_quat(p.yaw) for p in recipe.parts]
    shapes = [pb.GEOM_CYLINDER if p.cylinder else pb.GEOM_BOX for p in recipe.parts]
    radii = [p.half[0] for p in recipe.parts]
    lengths = [2 * p.half[2] for p in recipe.parts]
    collision = pb.createCollisionShapeArray(
        shapeTypes=shapes,
        halfExtents=[list(p.half) for p in recipe.parts],
        radii=radii,
        lengths=lengths,
        collisionFramePositions=positions,
        collisionFrameOrientations=orientations,
        physicsClientId=client,
    )
    visual = pb.createVisualShapeArray(
        shapeTypes=shapes,
        halfExtents=[list(p.half) for p in recipe.parts],
        radii=radii,
        lengths=lengths,
        visualFramePositions=positions,
        visualFrameOrientations=orientations,
        physicsClientId=client,
    )
    object_from_com = np.eye(4)
    object_from_com[:3, 3] = com
    world_from_com = world_from_object @ object_from_com
    body = pb.createMultiBody(
        baseMass=0.0 if fixed else recipe.mass,
        baseCollisionShapeIndex=collision,
        baseVisualShapeIndex=visual,
        basePosition=list(world_from_com[:3, 3]),
        baseOrientation=list(matrix_to_quat(world_from_com[:3, :3])),
        physicsClientId=client,
    )
    # Colours per shape afterwards: createVisualShapeArray's rgbaColors crashes PyBullet 3.2.7.
    for index, part in enumerate(recipe.parts):
        pb.changeVisualShape(body, -1, shapeIndex=index, rgbaColor=list(part.rgba), physicsClientId=client)
    pb.changeDynamics(
        body,
        -1,
        lateralFriction=recipe.lateral_friction,
        spinningFriction=recipe.spinning_friction,
        rollingFriction=recipe.rolling_friction,
        physicsClientId=client,
    )
    return BuiltBody(body, object_from_com)


def build_table(client: int) -> int:
    hx, hy, hz = TABLE_HALF_EXTENTS
    collision = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[hx, hy, hz], physicsClientId=client)
    visual = pb.createVisualShape(
        pb.GEOM_BOX,
        halfExtents=[hx, hy, hz],
        rgbaColor=[0.93, 0.9, 0.85, 1.0],
        physicsClientId=client,
    )
    body = pb.createMultiBody(
        0.0,
        collision,
        visual,
        basePosition=[TABLE_CENTRE_XY[0], TABLE_CENTRE_XY[1], TABLE_TOP_Z - hz],
        physicsClientId=client,
    )
    pb.changeDynamics(body, -1, lateralFriction=0.8, physicsClientId=client)
    return int(body)


def build_bead(client: int, position: FloatArray) -> int:
    """A small sphere of contents (a dried pea, roughly) for pouring."""
    collision = pb.createCollisionShape(pb.GEOM_SPHERE, radius=BEAD_RADIUS, physicsClientId=client)
    visual = pb.createVisualShape(
        pb.GEOM_SPHERE, radius=BEAD_RADIUS, rgbaColor=[0.95, 0.8, 0.1, 1.0], physicsClientId=client
    )
    body = pb.createMultiBody(
        BEAD_MASS, collision, visual, basePosition=list(position), physicsClientId=client
    )
    pb.changeDynamics(body, -1, lateralFriction=0.4, rollingFriction=0.001, physicsClientId=client)
    return int(body)
