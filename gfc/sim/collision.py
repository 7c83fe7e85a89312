"""Collision checks on the planning mirror: robots at trial configurations, held objects along.

A configuration is in collision when a moving body (an acting arm or an object one of them
holds) penetrates anything by more than ``PENETRATION_TOLERANCE``: the table, the other arm,
any object, or the arm itself (links two or more joints apart). Resting contact (the fingers on what they hold) is allowed; beads are ignored
because they are contents, not obstacles.

A held container listed in ``upright`` (one with contents) must also stay within its tilt
limit (``UPRIGHT_TILT``, or a little more than it leans in the hand already): a configuration that tilts it counts as a collision of the
container with "tilt", so motion planning keeps it upright the whole way, as a person carries
a full cup.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from gfc.geometry import FloatArray
from gfc.sim.panda import ARM_DOF, FINGER_JOINTS, HAND_LINKS, ee_matrix, set_joints
from gfc.sim.world import World, place_in_mirror

PENETRATION_TOLERANCE = 0.002
FINGER_LANDING = 0.001  # m: an open finger this deep in the object at a grasp lands on it
UPRIGHT_TILT = math.radians(25.0)  # rad a carried container with contents may tilt
# Link pairs of one arm that can collide: two or more joints apart (link -1 is the base; link 7
# is the massless flange, fixed to link 6 and the hand, so link 6 and the hand are neighbours;
# the fingers may touch each other and the hand).
SELF_PAIRS = tuple(
    (i, j) for i in range(-1, 7) for j in range(i + 2, 11) if j != 7 and not (i == 6 and j in (8, 9, 10))
)


@dataclass(frozen=True)
class Carried:
    """An object moving with a robot's end effector during a motion."""

    robot: str
    object: str
    ee_from_object: FloatArray


@dataclass(frozen=True)
class Collision:
    moving: str
    other: str


CollisionFn = Callable[[FloatArray], Collision | None]


def _self_contact(client: int, body: int, robot: str) -> Collision | None:
    """The first pair of one arm's links that interpenetrate where its joints are now."""
    for i, j in SELF_PAIRS:
        for contact in pb.getClosestPoints(
            body, body, 0.0, linkIndexA=i, linkIndexB=j, physicsClientId=client
        ):
            if contact[8] < -PENETRATION_TOLERANCE:
                return Collision(robot, f"itself (links {i} and {j})")
    return None


def self_collision_fn(world: World, robot: str) -> CollisionFn:
    """A test of ``robot``'s joints (7) against the arm itself only, on the mirror: for the
    straight lines that may touch the scene but must not fold the arm into itself."""
    mirror = world.mirror
    panda = mirror.robots[robot]

    def check(q: FloatArray) -> Collision | None:
        set_joints(mirror.client, panda, q, 0.04)
        return _self_contact(mirror.client, panda.body, robot)

    return check


def make_collision_fn(
    world: World,
    robots: Sequence[str],
    carried: Sequence[Carried] = (),
    fingers: dict[str, float] | None = None,
    allowed: frozenset[tuple[str, str]] = frozenset(),
    upright: Mapping[str, float] | None = None,
    clearance: float = 0.0,
    hand_clearance: float = 0.0,
) -> CollisionFn:
    """A checker for the stacked joint vector of ``robots`` (7 per robot, in that order).

    ``allowed`` holds (moving, other) name pairs that may touch (a gripper and the object it is
    about to grasp); ``upright`` the carried objects that must stay upright, each with the tilt
    (rad) it may reach (a collision with "tilt" beyond it); ``clearance`` (m) the distance a
    carried object must keep from everything it may not touch (a path planned with none skims
    box walls within millimetres, and the executed path, a few millimetres off, catches the
    carried block on the wall); ``hand_clearance`` (m) the distance each moving robot's hand and
    fingers keep from the objects they may not touch (not the table, not what the hand holds).
    Returns the first collision found, or ``None`` when the configuration is free.
    """
    min_cos = {name: math.cos(tilt) for name, tilt in (upright or {}).items()}
    mirror = world.mirror
    client = mirror.client
    name_of_body = {r.body: n for n, r in mirror.robots.items()}
    name_of_body.update({o.body: n for n, o in mirror.objects.items()})
    name_of_body[mirror.table] = "table"
    bead_bodies = set(mirror.beads)
    finger_half = {r: (fingers or {}).get(r, 0.04) / 2 for r in robots}
    holders: dict[str, set[str]] = {}
    for c in carried:
        holders.setdefault(c.object, set()).add(c.robot)
    moving_bodies = [mirror.robots[r].body for r in robots] + [mirror.objects[o].body for o in holders]
    # Every object on the mirror is static (massless: the mirror is never stepped), and Bullet
    # reports no contacts between two static bodies: a carried object's penetration of another
    # object or the table is found by a closest-points query instead (until session 20 it went
    # unseen: a hook turned across the box rested its shaft on the box's wall, type 3).
    static_bodies = {o.body: n for n, o in mirror.objects.items()}
    static_bodies[mirror.table] = "table"

    def touching_allowed(moving: str, other: str, moving_link: int, other_link: int) -> bool:
        if (moving, other) in allowed or (other, moving) in allowed:
            return True
        # A held object may touch the hand that holds it.
        if moving in holders and other in holders[moving] and other_link in HAND_LINKS:
            return True
        return other in holders and moving in holders[other] and moving_link in HAND_LINKS

    def check(q: FloatArray) -> Collision | None:
        for i, r in enumerate(robots):
            set_joints(client, mirror.robots[r], q[i * ARM_DOF : (i + 1) * ARM_DOF], finger_half[r])
        tilted = None
        for c in carried:
            world_from_object = ee_matrix(client, mirror.robots[c.robot]) @ c.ee_from_object
            place_in_mirror(mirror, c.object, world_from_object)
            if c.object in min_cos and world_from_object[2, 2] < min_cos[c.object]:
                tilted = c.object
        if tilted is not None:
            return Collision(tilted, "tilt")
        for r in robots:
            hit = _self_contact(client, mirror.robots[r].body, r)
            if hit is not None:
                return hit
        pb.performCollisionDetection(physicsClientId=client)
        for body in moving_bodies:
            for contact in pb.getContactPoints(bodyA=body, physicsClientId=client):
                other_body, link_a, link_b, distance = (
                    contact[2],
                    contact[3],
                    contact[4],
                    contact[8],
                )
                if distance > -PENETRATION_TOLERANCE or other_body in bead_bodies or other_body == body:
                    continue
                moving, other = name_of_body[body], name_of_body.get(other_body, "?")
                if not touching_allowed(moving, other, link_a, link_b):
                    return Collision(moving, other)
        for name in holders:
            body = mirror.objects[name].body
            for other_body, other in static_bodies.items():
                if other_body == body or touching_allowed(name, other, -1, -1):
                    continue
                for point in pb.getClosestPoints(body, other_body, 0.0, physicsClientId=client):
                    if point[8] < -PENETRATION_TOLERANCE:
                        return Collision(name, other)
        if clearance > 0.0:
            for name in holders:
                body = mirror.objects[name].body
                for other_body, other in name_of_body.items():
                    if other_body == body:
                        continue
                    for point in pb.getClosestPoints(body, other_body, clearance, physicsClientId=client):
                        if not touching_allowed(name, other, -1, point[4]):
                            return Collision(name, f"{other} (within {clearance * 100:.0f} cm)")
        if hand_clearance > 0.0:
            for r in robots:
                body = mirror.robots[r].body
                for other_body, other in static_bodies.items():
                    if other == "table" or r in holders.get(other, ()):
                        continue
                    for point in pb.getClosestPoints(
                        body, other_body, hand_clearance, physicsClientId=client
                    ):
                        if point[3] in HAND_LINKS and not touching_allowed(r, other, point[3], -1):
                            return Collision(r, f"{other} (the hand within {hand_clearance * 100:.0f} cm)")
        return None

    return check


def first_collision_on_segment(
    check: CollisionFn, a: FloatArray, b: FloatArray, resolution: float = 0.03
) -> Collision | None:
    """Check a straight joint-space segment every ``resolution`` radians (max-norm)."""
    n = max(2, int(np.ceil(np.max(np.abs(b - a)) / resolution)) + 1)
    for t in np.linspace(0.0, 1.0, n):
        hit = check(a + t * (b - a))
        if hit is not None:
            return hit
    return None


def finger_depth(world: World, robot: str, obj: str) -> float:
    """How deep (m, 0 when clear) either finger of ``robot`` reaches into ``obj`` on the planning
    mirror as it stands: an open hand at a grasp with a finger inside the object comes down on
    its top instead of around it (ADR 0011)."""
    mirror = world.mirror
    body, target = mirror.robots[robot].body, mirror.objects[obj].body
    distances = [
        point[8]
        for finger in FINGER_JOINTS
        for point in pb.getClosestPoints(body, target, 0.0, linkIndexA=finger, physicsClientId=mirror.client)
    ]
    return max(0.0, -min(distances, default=0.0))
