"""Scenes in which one skill model's skill can be tried, with a heuristic and a uniform action prior.

A *scenario* is a small plan: set-up steps with fixed heuristic actions (pick the object so
that a ``place`` has something to put down), then the *target stage*: the step (or the group of
steps, for the two-handed pot) whose transition the model learns. Only the target stage's
actions are drawn from the prior; its pre nodes are read from the simulator after the set-up ran,
so they are the states the robot really reached, not the ones the set-up asked for.

The priors are deliberately broad and task-agnostic: grasps anywhere along a hammer's handle with
the hand either way round, end-effector targets anywhere in a box in front of the arm, objects in
random places on the table in front of either arm. Nothing here is copied from a benchmark task's
scene; the tasks must be reached by composing these skills.

Every pose action is a 9-vector (position, first two rotation columns). The heuristic proposal
includes its own noise (a distribution, not a point); ``uniform`` draws from a plausible box
around the relevant object with a uniformly random rotation (the baseline that ``gfc skills
check`` compares against, and a share of the collection prior).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from gfc.geometry import FloatArray, matrix_to_pose9, pose7_to_matrix, pose9_to_matrix
from gfc.kinds import OBJECT_KINDS
from gfc.plan.schema import PlanRequest
from gfc.tasks.base import DOWN, LEFT_BASE, RIGHT_BASE, TABLE_Z, pose7, rot_z

BASES = {"left": LEFT_BASE, "right": RIGHT_BASE}
OTHER = {"left": "right", "right": "left"}
Rng = np.random.Generator
State = dict[str, Any]  # {"poses": {entity: world pose7}, "grippers": {robot: opening}}
# Draws actions for the target steps, given the state the set-up left (a proposal may aim
# relative to where things really are, e.g. turn the hand from its current orientation).
ActionDraw = Callable[[Rng, State], list[FloatArray]]


@dataclass(frozen=True)
class Scenario:
    """A one-stage experiment for one skill model, after a (possibly empty) set-up."""

    plan: PlanRequest  # set-up steps, then the target stage (the last ``n_target`` steps)
    setup_actions: list[FloatArray | None]
    n_target: int
    propose: ActionDraw  # heuristic actions (with their own noise) for the target steps
    uniform: ActionDraw  # uniformly random actions for the target steps
    contents: dict[str, int] | None = None
    # Labelled by the kinematic screen instead of by execution (gfc.data.collect): the target
    # stage's pre-state is kept when the set-up's poses are reachable without collision and the
    # target stage's precondition holds there. For a terminal skill whose executions are too slow
    # and rare to collect (a pour: ~13 s each, 1 in 12 succeeding from random meetings).
    kinematic: bool = False

    @property
    def n_setup(self) -> int:
        return len(self.plan.skeleton) - self.n_target


ScenarioSampler = Callable[[Rng], Scenario]


# ---------------------------------------------------------------------------------- small helpers
def rot_x(angle: float) -> FloatArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def random_rotation(rng: Rng) -> FloatArray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return pose7_to_matrix([0, 0, 0, *q])[:3, :3]


def pose9(position: FloatArray | list[float], rotation: FloatArray) -> FloatArray:
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = position
    return matrix_to_pose9(out)


def uniform_pose(rng: Rng, low: list[float], high: list[float]) -> FloatArray:
    return pose9(rng.uniform(low, high), random_rotation(rng))


def in_front(
    rng: Rng, robot: str, reach: tuple[float, float] = (0.35, 0.55), spread: float = 0.15
) -> tuple[float, float]:
    """A table position in front of ``robot``'s base."""
    bx, by, _ = BASES[robot]
    return bx + rng.uniform(*reach), by + rng.uniform(-spread, spread)


def make_plan(objects: list[dict[str, object]], skeleton: list[dict[str, object]]) -> PlanRequest:
    return PlanRequest.model_validate(
        {
            "scene": {
                "robots": [{"name": n, "base": list(b)} for n, b in BASES.items()],
                "objects": objects,
            },
            "skeleton": skeleton,
        }
    )


def box_uniform(kind: str, margin: float = 0.02) -> ActionDraw:
    """A grasp anywhere in (and a little around) the object's bounding box, any rotation."""
    half = OBJECT_KINDS[kind].half_extents
    low = [-half[0] - margin, -half[1] - margin, 0.0]
    high = [half[0] + margin, half[1] + margin, 2 * half[2] + margin]
    return lambda rng, _state: [uniform_pose(rng, low, high)]


# ---------------------------------------------------------------------------------- grasps
def grasp_proposal(kind: str, rng: Rng, facing: float | None = None) -> FloatArray:
    """A heuristic grasp of ``kind`` in its object frame, with noise: the broad prior of pick.
    ``facing``: for side grasps, the direction (radians, in the object frame) the hand should
    travel as it approaches, i.e. away from the robot's base; ``None``: any direction."""
    half = OBJECT_KINDS[kind].half_extents
    jitter = rng.normal(0.0, [0.006, 0.006, 0.004])
    flip = float(rng.choice([0.0, math.pi]))  # the hand either way round
    if kind in ("cube", "block"):
        rotation = rot_z(rng.uniform(-math.pi, math.pi)) @ DOWN
        return pose9(np.array([0.0, 0.0, 2 * half[2] - 0.015]) + jitter, rotation)
    if kind == "hammer":  # anywhere along the handle, fingers across it
        position = [rng.uniform(-0.11, 0.05), 0.0, 0.018]
        return pose9(np.asarray(position) + jitter, rot_z(flip + rng.normal(0.0, 0.15)) @ DOWN)
    if kind == "hook":  # along the shaft (at y = -4.5 cm in the hook frame), away from the hook
        position = [rng.uniform(-0.17, 0.05), -0.045, 0.018]
        return pose9(np.asarray(position) + jitter, rot_z(flip + rng.normal(0.0, 0.15)) @ DOWN)
    if kind == "lid":  # the knob from above
        knob_z = OBJECT_KINDS["lid"].frames["knob"][2]
        return pose9(np.array([0.0, 0.0, knob_z]) + jitter, rot_z(rng.uniform(-math.pi, math.pi)) @ DOWN)
    if kind in ("nail", "mug", "cup"):
        out: FloatArray = side_grasp(kind, rng, facing) + np.concatenate([jitter, np.zeros(6)])
        return out
    raise KeyError(f"no grasp heuristic for {kind!r}")


# Side grasp: approach (hand z) horizontal along the object's -x, fingers (hand y) along the
# object's y, the hand's x axis up; rotated about the object's z for other approach directions.
SIDE = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
SIDE_HEIGHT = {"nail": (0.03, 0.06), "mug": (0.06, 0.09), "cup": (0.035, 0.055)}
SIDE_DEPTH = {"nail": 0.0, "mug": 0.005, "cup": 0.005}


def side_grasp(kind: str, rng: Rng, facing: float | None = None) -> FloatArray:
    """From the side, at a random height; approaching along ``facing`` give or take 35 degrees
    (from the robot's side: a far-side approach is rarely reachable), or from any azimuth. A mug
    is never approached across its handle (at -x)."""
    if facing is None:
        azimuth = rng.uniform(-math.pi, math.pi)
    else:  # SIDE approaches along -x at azimuth 0, i.e. travelling in direction pi
        azimuth = math.remainder(facing - math.pi + rng.uniform(-0.6, 0.6), 2 * math.pi)
    if kind == "mug":
        azimuth = float(np.clip(azimuth, -1.6, 1.6))
    z = rng.uniform(*SIDE_HEIGHT[kind])
    rotation = rot_z(azimuth) @ SIDE
    offset = rot_z(azimuth) @ np.array([SIDE_DEPTH[kind], 0.0, 0.0])
    return pose9([offset[0], offset[1], z], rotation)


def facing_from(robot: str, x: float, y: float, yaw: float) -> float:
    """The direction from ``robot``'s base to (x, y), in the frame of an object turned by ``yaw``."""
    bx, by, _ = BASES[robot]
    return math.atan2(y - by, x - bx) - yaw


# ---------------------------------------------------------------------------------- pick
def pick(kind: str) -> ScenarioSampler:
    """An object of ``kind`` lying free on the table in front of a random arm."""

    def sample(rng: Rng) -> Scenario:
        robot = str(rng.choice(["left", "right"]))
        x, y = in_front(rng, robot)
        yaw = rng.uniform(-math.pi, math.pi)
        objects: list[dict[str, object]] = [{"name": "obj", "kind": kind, "pose": pose7(x, y, TABLE_Z, yaw)}]
        plan = make_plan(objects, [{"skill": "pick", "robot": robot, "object": "obj"}])
        facing = facing_from(robot, x, y, yaw)
        return Scenario(plan, [], 1, lambda r, _s: [grasp_proposal(kind, r, facing)], box_uniform(kind))

    return sample


POT_HANDLE_GRASP_X = 0.03


def pot_scene(rng: Rng) -> list[dict[str, object]]:
    px, py = 0.45 + rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05)
    return [{"name": "pot", "kind": "pot", "pose": pose7(px, py, TABLE_Z, rng.uniform(-0.3, 0.3))}]


def pot_grasps(rng: Rng, _state: State | None = None) -> list[FloatArray]:
    """Both handles from above (left arm the +y handle), each with its own noise."""
    out = []
    for side in ("left", "right"):
        handle = OBJECT_KINDS["pot"].frames[f"handle_{side}"]
        nominal = np.array([POT_HANDLE_GRASP_X + rng.uniform(-0.025, 0.02), handle[1], handle[2]])
        position = nominal + rng.normal(0.0, [0.0, 0.005, 0.004])
        out.append(pose9(position, rot_z(rng.normal(0.0, 0.15)) @ DOWN))
    return out


def pick_pot(rng: Rng) -> Scenario:
    """Both arms grasp the pot's handles and lift it together (one group)."""
    skeleton: list[dict[str, object]] = [
        {"skill": "pick", "robot": r, "object": "pot", "group": "grasp"} for r in ("left", "right")
    ]
    plan = make_plan(pot_scene(rng), skeleton)
    uniform = box_uniform("pot")
    return Scenario(plan, [], 2, pot_grasps, lambda r, s: uniform(r, s) + uniform(r, s))


# ---------------------------------------------------------------------------------- move
def hand_in_base(state: State, robot: str) -> FloatArray:
    """The robot's end-effector pose in its base frame (bases are not rotated)."""
    out = pose7_to_matrix(state["poses"][robot])
    out[:3, 3] -= BASES[robot]
    return out


def move_target(
    rng: Rng, robot: str, hand: FloatArray, hand_from_object: FloatArray | None = None
) -> FloatArray:
    """The move action in the base frame: the hand anywhere in a box in front of the arm that
    reaches past the middle of the table (where two arms meet to hand over or pour), turned
    about the vertical from where it is (so what it holds stays upright), slightly tilted; the
    action is the pose this puts the held object at (the hand's own pose when empty-handed)."""
    rotation = rot_z(rng.uniform(-math.pi / 2, math.pi / 2)) @ rot_x(rng.normal(0.0, 0.08)) @ hand[:3, :3]
    inward = -1.0 if BASES[robot][1] > 0 else 1.0  # towards the other arm
    y_range = sorted((0.3 * -inward, 0.5 * inward))
    low, high = [0.28, y_range[0], 0.12], [0.68, y_range[1], 0.45]
    target = pose9_to_matrix(pose9(rng.uniform(low, high), rotation))
    return matrix_to_pose9(target if hand_from_object is None else target @ hand_from_object)


# Anywhere the arm might reach (the Panda reaches 0.855 m from its shoulder, 0.33 m above the base).
MOVE_UNIFORM_BOX = ([-0.3, -0.9, -0.2], [0.9, 0.9, 1.0])


def move_uniform(rng: Rng, _state: State) -> list[FloatArray]:
    return [uniform_pose(rng, *MOVE_UNIFORM_BOX)]


def move(kind: str) -> ScenarioSampler:
    """Pick ``kind`` with a heuristic grasp, then move the hand (``empty``: no object)."""

    def sample(rng: Rng) -> Scenario:
        robot = str(rng.choice(["left", "right"]))

        def propose(r: Rng, state: State) -> list[FloatArray]:
            hand = pose7_to_matrix(state["poses"][robot])
            held = None if kind == "empty" else np.linalg.inv(hand) @ pose7_to_matrix(state["poses"]["obj"])
            return [move_target(r, robot, hand_in_base(state, robot), held)]

        if kind == "empty":
            return Scenario(make_plan([], [{"skill": "move", "robot": robot}]), [], 1, propose, move_uniform)
        x, y = in_front(rng, robot)
        yaw = rng.uniform(-math.pi, math.pi)
        objects: list[dict[str, object]] = [{"name": "obj", "kind": kind, "pose": pose7(x, y, TABLE_Z, yaw)}]
        skeleton: list[dict[str, object]] = [
            {"skill": "pick", "robot": robot, "object": "obj"},
            {"skill": "move", "robot": robot, "object": "obj"},
        ]
        setup: list[FloatArray | None] = [grasp_proposal(kind, rng, facing_from(robot, x, y, yaw))]
        return Scenario(make_plan(objects, skeleton), setup, 1, propose, move_uniform)

    return sample


def move_pot(rng: Rng) -> Scenario:
    """Both arms lift the pot, then carry it rigidly: turned about the vertical through its centre
    and shifted a little; each hand's target follows from the pot's and the hands' real poses."""
    skeleton: list[dict[str, object]] = [
        {"skill": skill, "robot": r, "object": "pot", "group": group}
        for skill, group in (("pick", "grasp"), ("move", "turn"))
        for r in ("left", "right")
    ]

    def propose(r: Rng, state: State) -> list[FloatArray]:
        pot = pose7_to_matrix(state["poses"]["pot"])
        moved = pot.copy()
        moved[:3, :3] = rot_z(r.uniform(-1.0, 1.0)) @ pot[:3, :3]  # turns of up to 57 degrees
        moved[:3, 3] += r.uniform([-0.04, -0.04, 0.0], [0.04, 0.04, 0.08])
        out = []
        for robot in ("left", "right"):  # the action: the pot's pose in each arm's base frame
            target = moved.copy()
            target[:3, 3] -= BASES[robot]
            out.append(matrix_to_pose9(target))
        return out

    plan = make_plan(pot_scene(rng), skeleton)
    return Scenario(
        plan, list(pot_grasps(rng)), 2, propose, lambda r, s: move_uniform(r, s) + move_uniform(r, s)
    )


# ---------------------------------------------------------------------------------- place
LID_PLATE_TOP = 0.012  # m: a cube resting on the lid's plate has its bottom here (lid frame)
BOX_FLOOR = 0.01
BOX_RIM = 2 * OBJECT_KINDS["box"].half_extents[2]


def side_by_side(rng: Rng, robot: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """Two table spots in front of ``robot``: the target further out, the object towards the
    middle of the table (so that both arms' scenes mirror each other)."""
    bx, by, _ = BASES[robot]
    outward = 1.0 if by > 0 else -1.0
    target = (bx + rng.uniform(0.45, 0.55), by + outward * rng.uniform(0.1, 0.2))
    obj = (bx + rng.uniform(0.32, 0.42), target[1] - outward * rng.uniform(0.28, 0.33))
    return target, obj


def place_cube_on_lid(rng: Rng) -> Scenario:
    robot = str(rng.choice(["left", "right"]))
    (tx, ty), (ox, oy) = side_by_side(rng, robot)
    objects: list[dict[str, object]] = [
        {"name": "lid", "kind": "lid", "pose": pose7(tx, ty, TABLE_Z, rng.uniform(-0.3, 0.3))},
        {"name": "obj", "kind": "cube", "pose": pose7(ox, oy, TABLE_Z, rng.uniform(-math.pi, math.pi))},
    ]

    def propose(r: Rng, _state: State) -> list[FloatArray]:
        while True:  # anywhere on the plate, clear of the knob
            x, y = r.uniform(-0.12, 0.12), r.uniform(-0.07, 0.07)
            if abs(x) > 0.05 or abs(y) > 0.05:
                break
        z = LID_PLATE_TOP + r.normal(0.0, 0.002)
        return [pose9([x, y, z], rot_z(r.uniform(-math.pi, math.pi)))]

    half = OBJECT_KINDS["lid"].half_extents
    uniform = lambda r, _s: [uniform_pose(r, [-half[0], -half[1], 0.0], [half[0], half[1], 0.1])]  # noqa: E731
    return _place_scenario(robot, objects, "lid", grasp_proposal("cube", rng), propose, uniform)


def _place_scenario(
    robot: str,
    objects: list[dict[str, object]],
    target: str,
    grasp: FloatArray,
    propose: ActionDraw,
    uniform: ActionDraw,
) -> Scenario:
    skeleton: list[dict[str, object]] = [
        {"skill": "pick", "robot": robot, "object": "obj"},
        {"skill": "place", "robot": robot, "object": "obj", "target": target},
    ]
    return Scenario(make_plan(objects, skeleton), [grasp], 1, propose, uniform)


def _box_uniform(r: Rng, _state: State) -> list[FloatArray]:
    half = OBJECT_KINDS["box"].half_extents
    return [uniform_pose(r, [-half[0], -half[1], 0.0], [half[0], half[1], BOX_RIM + 0.08])]


def place_in_box(kind: str) -> ScenarioSampler:
    """Put ``kind`` into (hammer) or onto (lid: cover it) a fixed open box."""

    def sample(rng: Rng) -> Scenario:
        robot = str(rng.choice(["left", "right"]))
        (tx, ty), (ox, oy) = side_by_side(rng, robot)
        objects: list[dict[str, object]] = [
            {
                "name": "box",
                "kind": "box",
                "pose": pose7(tx, ty, TABLE_Z, rng.uniform(-0.2, 0.2)),
                "fixed": True,
            },
            {"name": "obj", "kind": kind, "pose": pose7(ox, oy, TABLE_Z, rng.uniform(-0.4, 0.4))},
        ]

        def propose(r: Rng, _state: State) -> list[FloatArray]:
            flip = float(r.choice([0.0, math.pi]))
            if kind == "lid":
                position = [r.normal(0.0, 0.006), r.normal(0.0, 0.006), BOX_RIM + 0.003]
                return [pose9(position, rot_z(flip + r.normal(0.0, 0.04)))]
            floor = BOX_FLOOR + 0.004 + r.normal(0.0, 0.002)
            if kind in ("cube", "block"):  # anywhere on the floor, any heading
                position = [r.uniform(-0.1, 0.1), r.uniform(-0.06, 0.06), floor]
                return [pose9(position, rot_z(r.uniform(-math.pi, math.pi)))]
            position = [r.normal(0.0, 0.01), r.uniform(-0.03, 0.03), floor]
            return [pose9(position, rot_z(flip + r.normal(0.0, 0.08)))]

        return _place_scenario(robot, objects, "box", grasp_proposal(kind, rng), propose, _box_uniform)

    return sample


RACK_TOP = 2 * OBJECT_KINDS["rack"].half_extents[2]


def _rack_scene(rng: Rng, robot: str, kind: str) -> list[dict[str, object]]:
    """A fixed rack further out, its bar across the arm's view, and ``kind`` nearer the middle."""
    (tx, ty), (ox, oy) = side_by_side(rng, robot)
    rack_yaw = rng.uniform(-0.3, 0.3)
    return [
        {"name": "rack", "kind": "rack", "pose": pose7(tx + 0.05, ty, TABLE_Z, rack_yaw), "fixed": True},
        {"name": "obj", "kind": kind, "pose": pose7(ox, oy, TABLE_Z, rng.uniform(-0.4, 0.4))},
    ]


def _rack_uniform(r: Rng, _state: State) -> list[FloatArray]:
    half = OBJECT_KINDS["rack"].half_extents
    return [uniform_pose(r, [-half[0] - 0.2, -half[1], 0.0], [half[0] + 0.2, half[1], RACK_TOP + 0.08])]


def place_block_by_rack(rng: Rng) -> Scenario:
    """Put a block on the table beside the rack (in front of or behind its bar), any heading."""
    robot = str(rng.choice(["left", "right"]))

    def propose(r: Rng, _state: State) -> list[FloatArray]:
        x = float(r.choice([-1.0, 1.0])) * r.uniform(0.09, 0.2)
        position = [x, r.uniform(-0.2, 0.2), 0.004 + r.normal(0.0, 0.002)]
        return [pose9(position, rot_z(r.uniform(-math.pi, math.pi)))]

    objects = _rack_scene(rng, robot, "block")
    return _place_scenario(robot, objects, "rack", grasp_proposal("block", rng), propose, _rack_uniform)


def place_hook_on_rack(rng: Rng) -> Scenario:
    """Lay the hook on the rack's bar: its shaft along the bar, either way round, anywhere along
    it (the shaft's centre line lies 4.5 cm off the hook's origin, so the origin sits beside the
    bar on the side the hook end points to)."""
    robot = str(rng.choice(["left", "right"]))

    def propose(r: Rng, _state: State) -> list[FloatArray]:
        turn = float(r.choice([-math.pi / 2, math.pi / 2]))
        shaft = rot_z(turn) @ np.array([0.0, -0.045, 0.0])  # the shaft's centre in the rack frame
        position = [-shaft[0] + r.normal(0.0, 0.005), r.uniform(-0.06, 0.06), RACK_TOP + 0.003]
        return [pose9(position, rot_z(turn + r.normal(0.0, 0.04)))]

    objects = _rack_scene(rng, robot, "hook")
    return _place_scenario(robot, objects, "rack", grasp_proposal("hook", rng), propose, _rack_uniform)


# ---------------------------------------------------------------------------------- regrasp
def regrasp_hammer(rng: Rng) -> Scenario:
    """One arm picks the hammer near its head and holds it out between the arms, handle towards
    the other arm, which takes it by the handle (anywhere clear of the giver's fingers)."""
    giver = str(rng.choice(["left", "right"]))
    receiver = OTHER[giver]
    x, y = in_front(rng, giver, (0.3, 0.45), 0.1)
    objects: list[dict[str, object]] = [
        {"name": "obj", "kind": "hammer", "pose": pose7(x, y, TABLE_Z, rng.uniform(-0.5, 0.5))}
    ]
    grasp = pose9([rng.uniform(0.0, 0.05), 0.0, 0.018], rot_z(float(rng.choice([0.0, math.pi]))) @ DOWN)
    # Held out: the head towards the giver, the handle towards the receiver.
    towards_giver = math.pi / 2 if BASES[giver][1] > 0 else -math.pi / 2
    hammer = np.eye(4)
    hammer[:3, :3] = rot_z(towards_giver + rng.uniform(-0.3, 0.3))
    hammer[:3, 3] = [
        0.45 + rng.uniform(-0.05, 0.05),
        rng.uniform(-0.04, 0.04),
        TABLE_Z + rng.uniform(0.18, 0.3),
    ]
    held_out = hammer.copy()  # the move's action: the hammer's pose in the giver's base frame
    held_out[:3, 3] -= BASES[giver]
    skeleton: list[dict[str, object]] = [
        {"skill": "pick", "robot": giver, "object": "obj"},
        {"skill": "move", "robot": giver, "object": "obj"},
        {"skill": "regrasp", "robot": receiver, "object": "obj", "from": giver},
    ]

    def propose(r: Rng, _state: State) -> list[FloatArray]:
        position = [r.uniform(-0.11, -0.05), r.normal(0.0, 0.004), 0.018 + r.normal(0.0, 0.003)]
        return [pose9(position, rot_z(float(r.choice([0.0, math.pi])) + r.normal(0.0, 0.15)) @ DOWN)]

    setup: list[FloatArray | None] = [grasp, matrix_to_pose9(held_out)]
    return Scenario(make_plan(objects, skeleton), setup, 1, propose, box_uniform("hammer"))


# ---------------------------------------------------------------------------------- push, pull
HOOK_TIP = OBJECT_KINDS["hook"].frames["tip"]
HOOK_BAR_X = HOOK_TIP[0]  # the hook's short bar sits at the tip's x, across the shaft's end
PULL_BLOCK_IN_TOOL = (HOOK_BAR_X - 0.05, 0.01)  # the block just inside the bar, clear of the shaft
PUSH_BLOCK_IN_TOOL = (HOOK_BAR_X + 0.05, 0.01)  # the block just beyond the bar's outer face


def stroke_action(rng: Rng, block_in_tool: tuple[float, float], longest: float = 0.25) -> FloatArray:
    """(x, y, r, theta) in the block's approach frame (gfc/sim/skills/tools.py): the tool heading
    about straight away from the robot, with the block at about ``block_in_tool`` in the tool's
    frame, and a stroke length up to ``longest``."""
    theta = rng.normal(0.0, 0.25)
    tool = rot_z(theta)[:2, :2]
    offset = np.asarray(block_in_tool) + rng.normal(0.0, 0.006, size=2)
    # The block sits at the approach frame's origin, so the tool's origin is at -tool @ offset.
    tip = tool @ (np.asarray(HOOK_TIP[:2]) - offset)
    return np.array([tip[0], tip[1], rng.uniform(0.06, longest), theta])


def stroke_uniform(rng: Rng, _state: State) -> list[FloatArray]:
    xy = rng.uniform(-0.25, 0.25, size=2)
    return [np.array([xy[0], xy[1], rng.uniform(0.01, 0.3), rng.uniform(-math.pi, math.pi)])]


HOOK_HALF = OBJECT_KINDS["hook"].half_extents
BLOCK_CLEARANCE = 0.06  # m between the hook's outline and a block's centre when the scene starts
# Where blocks start, in the acting base's frame: ahead (x) and out to the side (lateral, positive
# away from the table's centre line). They cover the tasks' blocks (hook reach pulls from 0.85 m
# ahead, rearrangement push starts 0.65 m ahead and 3 cm inwards).
STROKE_BLOCK_AHEAD = {"push": (0.6, 0.8), "pull": (0.62, 0.88)}
STROKE_BLOCK_LATERAL = (-0.06, 0.22)
PULL_CLOSEST = 0.5  # m from the base: where the prior's longest pull leaves the block


def _clear_of_hook(block_xy: FloatArray, hook: tuple[float, float, float]) -> bool:
    """Whether a block centred at ``block_xy`` stands clear of the hook's bounding box."""
    hx, hy, yaw = hook
    local = rot_z(-yaw)[:2, :2] @ (block_xy - np.array([hx, hy]))
    return bool(
        abs(local[0]) > HOOK_HALF[0] + BLOCK_CLEARANCE or abs(local[1]) > HOOK_HALF[1] + BLOCK_CLEARANCE
    )


def stroke(skill: str) -> ScenarioSampler:
    """The robot picks the hook, then pulls a block towards its base (``pull``) or pushes it away
    (``push``)."""

    def sample(rng: Rng) -> Scenario:
        robot = str(rng.choice(["left", "right"]))
        bx, by, _ = BASES[robot]
        outward = 1.0 if by > 0 else -1.0
        hook = (bx + rng.uniform(0.4, 0.48), by - outward * rng.uniform(0.0, 0.08), rng.uniform(-0.3, 0.3))
        while True:
            block_at = np.array(
                [
                    bx + rng.uniform(*STROKE_BLOCK_AHEAD[skill]),
                    by + outward * rng.uniform(*STROKE_BLOCK_LATERAL),
                ]
            )
            if _clear_of_hook(block_at, hook):
                break
        objects: list[dict[str, object]] = [
            {"name": "obj", "kind": "hook", "pose": pose7(hook[0], hook[1], TABLE_Z, hook[2])},
            {
                "name": "block",
                "kind": "block",
                "pose": pose7(
                    float(block_at[0]), float(block_at[1]), TABLE_Z, rng.uniform(-math.pi, math.pi)
                ),
            },
        ]
        skeleton: list[dict[str, object]] = [
            {"skill": "pick", "robot": robot, "object": "obj"},
            {"skill": skill, "robot": robot, "object": "obj", "target": "block"},
        ]
        inside = PUSH_BLOCK_IN_TOOL if skill == "push" else PULL_BLOCK_IN_TOOL

        def propose(r: Rng, state: State) -> list[FloatArray]:
            if skill == "push":
                return [stroke_action(r, inside)]
            # A pull brings the hand towards the base, the tool's length behind the block; a long
            # pull of a near block folds the arm onto itself.
            block = np.asarray(state["poses"]["block"][:2])
            distance = float(np.linalg.norm(block - np.array([bx, by])))
            return [stroke_action(r, inside, longest=min(0.25, max(0.08, distance - PULL_CLOSEST)))]

        grasp = pose9(
            [rng.uniform(-0.15, -0.05), -0.045, 0.018], rot_z(float(rng.choice([0.0, math.pi]))) @ DOWN
        )
        return Scenario(make_plan(objects, skeleton), [grasp], 1, propose, stroke_uniform)

    return sample


# ---------------------------------------------------------------------------------- pour
POUR_RIM_DISTANCE = (0.015, 0.05)  # m between the rims' centres, in xy (the mug's inner radius: 2.7 cm)
POUR_CLEARANCE = (0.005, 0.06)  # m from the target's rim up to the source's bottom
POUR_MEET_BOX = ([0.33, -0.16, 0.08], [0.6, 0.16, 0.32])  # world (x, y, z above the table) of the target


def pour(source: str, target: str) -> ScenarioSampler:
    """One arm picks ``source`` (a container holding beads), the other picks ``target``; both move
    at once (one group) to a meeting somewhere between the arms, the source's rim roughly over the
    target's at a random offset, height and heading; then the source's arm pours. The model learns
    the pour's pre-state: the meetings the arms can reach together without collision, from which
    the pour's precondition holds and the arm can follow the tipping. Labelled kinematically
    (``Scenario.kinematic``): spills and in-hand slips are not in the data. A pour has no
    action: its rows are the pre nodes alone (the pourer's hand, the source, the target, in the
    pourer's base frame)."""
    source_kind, target_kind = OBJECT_KINDS[source], OBJECT_KINDS[target]
    assert source_kind.inner_half_extents is not None and target_kind.inner_half_extents is not None
    target_rim_z = target_kind.frames["rim"][2]

    def sample(rng: Rng) -> Scenario:
        pourer = str(rng.choice(["left", "right"]))
        holder = OTHER[pourer]
        towards_pourer = 1.0 if BASES[pourer][1] > 0 else -1.0
        sx, sy = in_front(rng, pourer, (0.38, 0.52), 0.1)
        tx, ty = in_front(rng, holder, (0.38, 0.52), 0.1)
        # Handles (a mug's -x) away from the robots, give or take; the target has none.
        source_yaw = math.pi + rng.uniform(-1.0, 1.0)
        target_yaw = rng.uniform(-math.pi, math.pi)
        objects: list[dict[str, object]] = [
            {"name": "src", "kind": source, "pose": pose7(sx, sy, TABLE_Z, source_yaw)},
            {"name": "dst", "kind": target, "pose": pose7(tx, ty, TABLE_Z, target_yaw)},
        ]
        skeleton: list[dict[str, object]] = [
            {"skill": "pick", "robot": pourer, "object": "src"},
            {"skill": "pick", "robot": holder, "object": "dst"},
            {"skill": "move", "robot": pourer, "object": "src", "group": "meet"},
            {"skill": "move", "robot": holder, "object": "dst", "group": "meet"},
            {"skill": "pour", "robot": pourer, "object": "src", "target": "dst"},
        ]
        low, high = POUR_MEET_BOX
        meet = rng.uniform(low, high) + np.array([0.0, 0.0, TABLE_Z])  # the target's origin, world
        # The source's rim centre beside the target's, on the pourer's side give or take 40 deg.
        heading = towards_pourer * math.pi / 2 + rng.uniform(-0.7, 0.7)
        distance = rng.uniform(*POUR_RIM_DISTANCE)
        rim = meet + np.array([0.0, 0.0, target_rim_z])
        source_at = rim + np.array(
            [distance * math.cos(heading), distance * math.sin(heading), rng.uniform(*POUR_CLEARANCE)]
        )
        # Upright, turned about the vertical a little from how each lay (the hands turn with them).
        target_pose = pose9(meet - BASES[holder], rot_z(target_yaw + rng.uniform(-0.6, 0.6)))
        source_pose = pose9(source_at - BASES[pourer], rot_z(source_yaw + rng.uniform(-0.6, 0.6)))
        setup: list[FloatArray | None] = [
            grasp_proposal(source, rng, facing_from(pourer, sx, sy, source_yaw)),
            grasp_proposal(target, rng, facing_from(holder, tx, ty, target_yaw)),
            source_pose,
            target_pose,
        ]
        nothing: ActionDraw = lambda _r, _s: [np.zeros(0)]  # noqa: E731
        plan = make_plan(objects, skeleton)
        return Scenario(plan, setup, 1, nothing, nothing, contents={"src": POUR_BEADS}, kinematic=True)

    return sample


POUR_BEADS = 6  # contents of the source, as in the Pour Cup task


# ---------------------------------------------------------------------------------- registry
SCENARIOS: dict[str, ScenarioSampler] = {
    **{f"pick.{k}": pick(k) for k in ("cube", "block", "hammer", "hook", "lid", "nail", "mug", "cup")},
    "pick.pot": pick_pot,
    **{f"move.{k}": move(k) for k in ("cube", "hammer", "nail", "mug", "cup", "hook", "empty")},
    "move.pot": move_pot,
    "place.cube.lid": place_cube_on_lid,
    "place.hammer.box": place_in_box("hammer"),
    "place.lid.box": place_in_box("lid"),
    "place.cube.box": place_in_box("cube"),
    "place.block.box": place_in_box("block"),
    "place.block.rack": place_block_by_rack,
    "place.hook.rack": place_hook_on_rack,
    "regrasp.hammer": regrasp_hammer,
    "push.hook.block": stroke("push"),
    "pull.hook.block": stroke("pull"),
    "pour.mug.cup": pour("mug", "cup"),
}


def scenario_for(model: str) -> ScenarioSampler:
    try:
        return SCENARIOS[model]
    except KeyError:
        known = ", ".join(sorted(SCENARIOS))
        raise KeyError(f"no scene sampler for skill model {model!r} (have: {known})") from None
