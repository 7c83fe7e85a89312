"""The entity catalogue: robot state layout and the object kinds a plan may name.

This is the single source of truth for object geometry that the plan compiler, the constraint
energies and the simulator share. Sizes are in metres, in the object's own frame, whose origin
is the centre of the object's bottom face (so an object resting on the table has z = table top).
Named frames (``hammer.head``) are poses in the object frame, ``[x, y, z, qx, qy, qz, qw]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from gfc.geometry import POSE9_DIM

# A robot node is its end-effector pose (9-vector, in the robot's base frame inside a skill model,
# in the world frame inside the factor graph) plus the gripper opening in metres.
ROBOT_STATE_DIM = POSE9_DIM + 1
OBJECT_STATE_DIM = POSE9_DIM
GRIPPER_OPEN = 0.08

# Panda end effector (link 11, panda_grasptarget) at the home configuration
# (gfc.sim.panda.HOME_JOINTS), in the base frame: pointing down, fingers along the base y axis.
# Forward kinematics gives (0.3070, 0.0000, 0.4853) and this rotation within 0.02 degrees;
# tests/sim/test_world.py checks it, so a plan that does not state its robots' poses starts here.
HOME_EE_POSE_IN_BASE = (0.307, 0.0, 0.485, 1.0, 0.0, 0.0, 0.0)

IDENTITY_FRAME = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)

# The Panda's shoulder (joint 2) stands this high over its base. Its hand is never farther than
# ~0.95 m from there (the sum of the link offsets; the most of 20,000 random configurations), and
# with a useful hand orientation rarely beyond PANDA_REACH: every hand pose of the tasks'
# reference solutions is within it (tests/test_plan.py), and the poses that the simulator's IK
# could not reach in the benchmark's hand-overs were at 0.84-1.2 m.
PANDA_SHOULDER_Z = 0.333
PANDA_REACH = 0.85
# The Panda finger's collision hull, closed on a face: it reaches FINGER_THICKNESS beyond the face
# at the height of a neighbour of the same size (16 mm into a block 9 mm away on the screen's
# mirror, tests/sim/test_screen.py) and is FINGER_WIDTH across.
FINGER_THICKNESS = 0.025  # m
FINGER_WIDTH = 0.029  # m

# The hook's working faces (gfc/sim/bodies.py ``_hook`` builds them), in the hook's frame: its
# tip bar spans x within HOOK_TIP_BAR_HALF_X of the ``tip`` frame and y over HOOK_TIP_BAR_Y; the
# shaft runs along x over HOOK_SHAFT_Y. A pull drags its target with the bar's inner face (-x);
# a push pushes it with the hook's far end (+x), bar and shaft together.
HOOK_TIP_BAR_HALF_X = 0.015
HOOK_TIP_BAR_Y = (-0.03, 0.06)
HOOK_SHAFT_Y = (-0.06, -0.03)
STROKE_SIGNS = {"push": 1.0, "pull": -1.0}  # a stroke's travel along the tool's x axis
# m between the hook's working face and its target where the hook comes down for a stroke (the
# tasks' reference strokes leave 1 cm). Planned at 0 mm, the tip bar came down on the block's
# edge and the pull slid over it (Hook Reach T1 seed 4, session 13).
STROKE_CLEARANCE = 0.01
MAX_STROKE = 0.3  # m: the longest push or pull the executor makes
# rad: how far a stroked block's face may be turned from the hook's face (folded to within 45
# degrees). The face turns a block it meets askew until they lie flat (in replayed pulls of Hook
# Reach T2 the block's yaw ended at the tool's, most within two degrees); met more askew the hook
# catches a corner: of GFC's 100 top-1 plans of Hook Reach T2 at commit a0e6f98, 9 of the 15
# pulls met more than 35 degrees askew failed (the block moved 0-4 cm of a planned 11-16, or
# ended out of reach), against 23 failures in all (session 22, scripts/replay_top1.py; ADR 0009).
MAX_STROKE_TURN = math.radians(35.0)
# m of the stroke over which a block met askew turns flat against the face (the pivot shift of
# ``pivot_shift`` fades in over it; the pivot of a block met 30 degrees askew takes 0.9 cm).
PIVOT_TRAVEL = 0.01


def folded_turn(yaw: float) -> float:
    """A box's yaw relative to a face, folded to [-45, 45) degrees (a box is the same every
    quarter turn)."""
    quarter = math.pi / 2
    return (yaw + quarter / 2) % quarter - quarter / 2


def pivot_shift(turn: float, half_x: float, half_y: float) -> tuple[float, float]:
    """Where a box met askew by a face ends relative to where sliding alone would put it: (along
    the stroke, across it, m; across is +90 degrees from the direction of travel). ``turn``: the
    box's yaw from the face's (rad; a half turn gives the same). The face meets the box's
    leading corner and turns the box about it until a side lies flat; the corner stays where it
    met the face across the stroke. So the centre ends short by the extent it had along the
    stroke less the flat box's, and to the side by the corner's lateral offset less the flat
    box's half side. A 5 cm block met 30 degrees askew: 0.9 cm short, 1.6 cm aside; before this
    the model turned the block about its centre and replayed Rearrangement Push T1 pushes ended
    1.5-2 cm aside of it at 28-34 degrees, 0.4 cm at 7 (session 23, scripts/replay_top1.py
    --strokes)."""
    c, s = math.cos(turn), math.sin(turn)
    extent = half_x * abs(c) + half_y * abs(s)
    # The leading corner, (-sgn c * half_x, sgn s * half_y) turned by ``turn``: its lateral offset.
    lateral = -math.copysign(1.0, c) * half_x * s + (math.copysign(1.0, s) if s else 0.0) * half_y * c
    flat = turn - folded_turn(turn)  # a quarter turn's multiple
    along_flat = half_x * abs(math.cos(flat)) + half_y * abs(math.sin(flat))
    across_flat = half_x * abs(math.sin(flat)) + half_y * abs(math.cos(flat))
    side = math.copysign(1.0, lateral) if lateral else 0.0
    return along_flat - extent, lateral - side * across_flat


def hook_face_span(sign: float) -> tuple[float, float]:
    """The y span (hook frame) of the face that moves a target: the tip bar's inner face for a
    pull (``sign`` -1), the hook's whole far end, bar and shaft, for a push (+1)."""
    return (HOOK_SHAFT_Y[0], HOOK_TIP_BAR_Y[1]) if sign > 0 else HOOK_TIP_BAR_Y


@dataclass(frozen=True)
class ObjectKind:
    """Geometry and affordances of one kind of object."""

    name: str
    description: str
    half_extents: tuple[float, float, float]  # bounding box half sizes in the object frame
    frames: dict[str, tuple[float, ...]] = field(default_factory=dict)  # name -> pose7
    inner_half_extents: tuple[float, float, float] | None = None  # open region of a container
    graspable: bool = True
    # Objects placed by it are released outside its bounding box (beside it, or on top): it
    # has no opening, and a hand cannot reach in under it (the rack's bar).
    release_outside: bool = False

    @property
    def is_container(self) -> bool:
        return self.inner_half_extents is not None

    @property
    def quarter_turn_symmetric(self) -> bool:
        """Whether a quarter turn about the vertical axis leaves it as it was: a square footprint
        and no named frames (a block). A grasp or placement of it turned so is the same one."""
        hx, hy, _ = self.half_extents
        return hx == hy and not self.frames and not self.is_container

    def frame(self, name: str | None) -> tuple[float, ...]:
        """The pose of a named frame in the object frame; ``None`` is the object frame."""
        if name is None or name == "base":
            return IDENTITY_FRAME
        if name not in self.frames:
            known = ", ".join(sorted(["base", *self.frames])) or "base"
            raise KeyError(f"object kind {self.name!r} has no frame {name!r} (known: {known})")
        return self.frames[name]


def _kinds(*kinds: ObjectKind) -> dict[str, ObjectKind]:
    return {k.name: k for k in kinds}


OBJECT_KINDS: dict[str, ObjectKind] = _kinds(
    ObjectKind(
        "hammer",
        "handle (x axis, 0.24 m) with a head at +x; grasp the handle to strike",
        half_extents=(0.12, 0.05, 0.0175),
        frames={
            "head": (0.095, 0.0, 0.0175, 0.0, 0.0, 0.0, 1.0),
            "handle": (-0.03, 0.0, 0.0125, 0.0, 0.0, 0.0, 1.0),
            "handle_end": (-0.10, 0.0, 0.0125, 0.0, 0.0, 0.0, 1.0),
        },
    ),
    ObjectKind(
        "nail",
        "a stake standing upright, 0.08 m tall",
        half_extents=(0.012, 0.012, 0.04),
        frames={"top": (0.0, 0.0, 0.08, 0.0, 0.0, 0.0, 1.0)},
    ),
    ObjectKind("cube", "a 4 cm cube", half_extents=(0.02, 0.02, 0.02)),
    ObjectKind("block", "a 5 cm block for pushing and packing", half_extents=(0.025, 0.025, 0.025)),
    ObjectKind(
        "lid",
        "a flat lid with a knob on top",
        half_extents=(0.16, 0.11, 0.02),
        frames={"knob": (0.0, 0.0, 0.03, 0.0, 0.0, 0.0, 1.0)},
    ),
    ObjectKind(
        "box",
        "an open box with thin walls, long enough for the hammer",
        half_extents=(0.15, 0.1, 0.04),
        inner_half_extents=(0.14, 0.09, 0.04),
        graspable=False,
    ),
    ObjectKind(
        "mug",
        "a narrow mug opening along +z, handle at -x",
        half_extents=(0.035, 0.035, 0.05),
        frames={"rim": (0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 1.0)},
        inner_half_extents=(0.027, 0.027, 0.05),
    ),
    ObjectKind(
        "cup",
        "a wider, shorter cup opening along +z, no handle",
        half_extents=(0.034, 0.034, 0.04),
        frames={"rim": (0.0, 0.0, 0.08, 0.0, 0.0, 0.0, 1.0)},
        inner_half_extents=(0.029, 0.029, 0.04),
    ),
    ObjectKind(
        "pot",
        "a pot with two handles along +y and -y",
        half_extents=(0.12, 0.2, 0.06),
        frames={
            "handle_left": (0.0, 0.185, 0.1, 0.0, 0.0, 0.0, 1.0),
            "handle_right": (0.0, -0.185, 0.1, 0.0, 0.0, 0.0, 1.0),
        },
        inner_half_extents=(0.1, 0.1, 0.06),
    ),
    ObjectKind(
        "hook",
        "an L-shaped tool: a long shaft along x and a short hook along +y at its far end",
        half_extents=(0.2, 0.06, 0.015),
        frames={"tip": (0.185, 0.05, 0.015, 0.0, 0.0, 0.0, 1.0)},
    ),
    ObjectKind(
        "rack",
        "a table-mounted bar on two legs; objects can be pushed underneath",
        half_extents=(0.05, 0.25, 0.06),
        graspable=False,
        release_outside=True,
    ),
)


def object_kind(name: str) -> ObjectKind:
    try:
        return OBJECT_KINDS[name]
    except KeyError:
        known = ", ".join(sorted(OBJECT_KINDS))
        raise KeyError(f"unknown object kind {name!r} (known: {known})") from None
