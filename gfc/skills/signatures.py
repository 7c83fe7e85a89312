"""Skill signatures: which entities a skill reads and writes, and what its action means.

A skill model sees one token per node it touches, in a fixed order:
``[pre nodes (roles in order)] + [action] + [effect nodes (written roles in order)]``.
Robot and object nodes inside a model are expressed in the *acting robot's base frame*, so one
model serves both arms; actions are already in frames local to the skill (object frame for
grasps, target frame for placements, base frame for end-effector targets).

Holding rules (checked by the plan compiler) are part of the signature, because they are what
makes a skeleton symbolically feasible:

- ``requires_held``: the acting robot must hold the step's ``object`` before the step.
- ``requires_free``: the acting robot must hold nothing before the step.
- ``grasps`` / ``releases``: the step makes the robot hold / let go of ``object``.
- ``hands_over``: the ``from`` robot holds ``object`` before and lets go of it after.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from gfc.kinds import OBJECT_STATE_DIM, ROBOT_STATE_DIM

Role = Literal["robot", "object", "target", "from"]
TokenKind = Literal["robot", "object", "action"]
Phase = Literal["pre", "action", "effect"]

ROLE_KIND: dict[Role, TokenKind] = {
    "robot": "robot",
    "object": "object",
    "target": "object",
    "from": "robot",
}
KIND_DIM: dict[TokenKind, int] = {"robot": ROBOT_STATE_DIM, "object": OBJECT_STATE_DIM}

POSE_ACTION = ("x", "y", "z", "r11", "r21", "r31", "r12", "r22", "r32")
PICK_LIFT = 0.12  # m a pick lifts the grasped object straight up (part of what "pick" means)
POUR_UPRIGHT_DEG = 15.0  # a pour starts with both containers within this of vertical
# Cosine of the angle between the holding hand's approach (horizontal part) and the pouring
# direction, at least: below it the palm and fingers are between source and target and the
# contents pour onto them (ADR 0013). Just below 0 (about a degree past side-on), so that a hand
# side-on to the pour, as in the task's reference actions, passes.
POUR_PALM_TOWARDS = -0.02


@dataclass(frozen=True)
class TokenSpec:
    """One token of a skill model: a node in a role, before or after the skill, or the action."""

    role: Role | Literal["action"]
    kind: TokenKind
    phase: Phase
    dim: int


@dataclass(frozen=True)
class SkillSpec:
    name: str
    description: str
    reads: tuple[Role, ...]  # roles whose node before the step is a token
    writes: tuple[Role, ...]  # roles that get a new node version after the step
    action_names: tuple[str, ...]
    action_frame: str
    requires_held: bool = False
    requires_free: bool = False
    grasps: bool = False
    releases: bool = False
    hands_over: bool = False
    object_required: bool = True
    target_required: bool = False
    # The action is the effect node of the first of these roles the step has (move: the held
    # object, or the hand when it holds nothing).
    action_is_effect_of: tuple[Role, ...] = ()
    # A terminal skill (no action, no effects) whose pre-state has a learned model: a factor
    # over its pre nodes alone (where the skill can start), e.g. the meetings a pour works from.
    learned_precondition: bool = False

    @property
    def action_dim(self) -> int:
        return len(self.action_names)

    @property
    def roles(self) -> tuple[Role, ...]:
        """Every role the step names, in token order."""
        return self.reads

    def tokens(self, with_object: bool = True) -> tuple[TokenSpec, ...]:
        """Token layout of the skill model (``with_object=False`` for an empty-handed move)."""
        reads = [r for r in self.reads if with_object or r != "object"]
        writes = [r for r in self.writes if with_object or r != "object"]
        out = [TokenSpec(r, ROLE_KIND[r], "pre", KIND_DIM[ROLE_KIND[r]]) for r in reads]
        if self.action_dim:
            out.append(TokenSpec("action", "action", "action", self.action_dim))
        out += [TokenSpec(r, ROLE_KIND[r], "effect", KIND_DIM[ROLE_KIND[r]]) for r in writes]
        return tuple(out)


def _spec(*specs: SkillSpec) -> dict[str, SkillSpec]:
    return {s.name: s for s in specs}


SKILLS: dict[str, SkillSpec] = _spec(
    SkillSpec(
        "pick",
        "grasp an object that no robot holds",
        reads=("robot", "object"),
        writes=("robot", "object"),
        action_names=POSE_ACTION,
        action_frame="grasp (end-effector) pose in the object frame",
        requires_free=True,
        grasps=True,
    ),
    SkillSpec(
        "place",
        "put the held object down on or in the target",
        reads=("robot", "object", "target"),
        writes=("robot", "object"),
        action_names=POSE_ACTION,
        action_frame="object pose in the target frame",
        requires_held=True,
        releases=True,
        target_required=True,
    ),
    SkillSpec(
        "move",
        "move the end effector (and the held object, if any) to a new pose",
        reads=("robot", "object"),
        writes=("robot", "object"),
        action_names=POSE_ACTION,
        action_frame="pose of the held object (of the end effector when empty-handed) in the robot's base frame",
        requires_held=True,
        object_required=False,
        action_is_effect_of=("object", "robot"),
    ),
    SkillSpec(
        "regrasp",
        "take the object from the other robot's hand (handover)",
        reads=("robot", "object", "from"),
        writes=("robot", "object", "from"),
        action_names=POSE_ACTION,
        action_frame="grasp pose of the receiving robot in the object frame",
        requires_free=True,
        grasps=True,
        hands_over=True,
    ),
    SkillSpec(
        "push",
        "push the target with the held tool",
        reads=("robot", "object", "target"),
        writes=("robot", "object", "target"),
        action_names=("x", "y", "r", "theta"),
        action_frame="STAP/GSC push parameters in the target's approach frame (x: from the acting base to the target)",
        requires_held=True,
        target_required=True,
    ),
    SkillSpec(
        "pull",
        "pull the target towards the robot with the held tool",
        reads=("robot", "object", "target"),
        writes=("robot", "object", "target"),
        action_names=("x", "y", "r", "theta"),
        action_frame="STAP/GSC pull parameters in the target's approach frame (x: from the acting base to the target)",
        requires_held=True,
        target_required=True,
    ),
    SkillSpec(
        "strike",
        "strike the target with the held tool (terminal: its precondition only)",
        reads=("robot", "object", "target"),
        writes=(),
        action_names=(),
        action_frame="none",
        requires_held=True,
        target_required=True,
    ),
    SkillSpec(
        "pour",
        "pour the held container into the target (terminal: a learned model of its pre-state)",
        reads=("robot", "object", "target"),
        writes=(),
        action_names=(),
        action_frame="none",
        requires_held=True,
        target_required=True,
        learned_precondition=True,
    ),
)


def skill_spec(name: str) -> SkillSpec:
    try:
        return SKILLS[name]
    except KeyError:
        known = ", ".join(sorted(SKILLS))
        raise KeyError(f"unknown skill {name!r} (known: {known})") from None


def default_model_key(skill: str, object_kind: str | None, target_kind: str | None = None) -> str:
    """Skill models are trained per skill and object kind (``pick.hammer``, ``move.empty``), and
    per target kind for skills that act on a target (``place.hammer.box``, ``strike.hammer.nail``):
    where a cube goes on a lid and where it goes in a box are different distributions, and the
    model sees the target only as a pose."""
    key = f"{skill}.{object_kind or 'empty'}"
    return key if target_kind is None or not skill_spec(skill).target_required else f"{key}.{target_kind}"
