"""Optional kinematic links that a skill's meaning implies between its nodes and its action.

A skill model learns ``p(pre, action, effect)`` from data, and a small model trained on a few
hundred rows keeps relations that are exact in the world only approximately: an object carried
through ``move`` keeps its pose in the hand; a placed object rests at the place action's pose in
the target frame. With ``Options.kinematics`` on, the compiler states them as implied spatial
factors (source ``"implied"``), as it does for two hands holding one object. They are off by
default: on the benchmark they lowered success (docs/adr/0002-what-a-move-executes.md). Links
for pick and regrasp ("the hand ends at the grasp") are deliberately absent: objects such as the
mug swing in the fingers, so the data contradicts them.

Each link names its nodes by (role, phase) in the step's factor and, optionally, the step's
action, which the residual receives after the nodes. Tolerances are the physical slack: a carried
object shifts by millimetres in the hand, a placed object settles by up to a couple of centimetres.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from gfc.skills.signatures import Phase, Role

NodeRef = tuple[Role, Phase]


@dataclass(frozen=True)
class KinematicLink:
    type: str  # a residual in gfc.constraints.RESIDUALS
    nodes: tuple[NodeRef, ...]
    with_action: bool = False  # the step's action is the residual's last input
    params: dict[str, Any] = field(default_factory=dict)
    needs_object: bool = True  # only when the step names an object (an empty-handed move has none)


LINKS: dict[str, tuple[KinematicLink, ...]] = {
    # What the hand holds keeps its pose in the hand.
    "move": (
        KinematicLink(
            "fixed_transform",
            (("robot", "pre"), ("object", "pre"), ("robot", "effect"), ("object", "effect")),
            False,
            {"tolerance": 0.01, "transform": None},
        ),
    ),
    # The object comes to rest at the action's pose in the target frame (it settles a little).
    "place": (
        KinematicLink("relative_pose", (("target", "pre"), ("object", "effect")), True, {"tolerance": 0.02}),
    ),
}  # fmt: skip


def links_of(skill: str, with_object: bool) -> tuple[KinematicLink, ...]:
    return tuple(link for link in LINKS.get(skill, ()) if with_object or not link.needs_object)
