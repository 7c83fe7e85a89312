"""Compile a plan request into a spatial-temporal factor graph, or report every problem in it.

Each skeleton step reads the latest version of every entity it names and writes a new version
of each entity it changes. Steps sharing a ``group`` form one *stage*: they all read the state
before the stage and their effects appear together after it; an entity that several steps of a
stage change (a pot lifted by two arms) gets one new version shared by their factors.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from gfc.constraints import fingers_clear_params
from gfc.geometry import matrix_to_pose9, pose7_to_matrix, pose7_to_pose9, yaw_quat
from gfc.kinds import (
    HOME_EE_POSE_IN_BASE,
    HOOK_SHAFT_Y,
    HOOK_TIP_BAR_HALF_X,
    MAX_STROKE,
    MAX_STROKE_TURN,
    OBJECT_KINDS,
    OBJECT_STATE_DIM,
    PANDA_REACH,
    PANDA_SHOULDER_Z,
    ROBOT_STATE_DIM,
    STROKE_CLEARANCE,
    STROKE_SIGNS,
    hook_face_span,
)
from gfc.plan.graph import (
    ActionVariable,
    CompiledPlan,
    FactorToken,
    NodeVersion,
    SpatialFactor,
    TemporalFactor,
)
from gfc.plan.kinematics import links_of
from gfc.plan.schema import (
    Aligned,
    Apart,
    Far,
    FixedTransform,
    Inside,
    Near,
    PlanRequest,
    SpatialFactorSpec,
    Step,
    Yaw,
)
from gfc.skills.signatures import (
    POUR_PALM_TOWARDS,
    POUR_UPRIGHT_DEG,
    SKILLS,
    Role,
    SkillSpec,
    default_model_key,
)


@dataclass(frozen=True)
class PlanIssue:
    """One problem in a plan: where it is (``skeleton[2].from``) and what is wrong."""

    loc: str
    message: str

    def __str__(self) -> str:
        return f"{self.loc}: {self.message}"


class PlanError(ValueError):
    """Raised with every problem found in a plan, not just the first."""

    def __init__(self, issues: list[PlanIssue]) -> None:
        self.issues = issues
        super().__init__("invalid plan:\n" + "\n".join(f"  - {i}" for i in issues))

    def to_json(self) -> list[dict[str, str]]:
        return [{"loc": i.loc, "message": i.message} for i in self.issues]


def _loc_of(parts: tuple[Any, ...]) -> str:
    out = ""
    for p in parts:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += ("." if out else "") + str(p)
    return out or "plan"


def issues_from_errors(errors: Any, drop_prefix: tuple[str, ...] = ()) -> list[PlanIssue]:
    """Pydantic error dicts -> located ``PlanIssue``s whose locations read like JSON paths."""
    issues = []
    for err in errors:
        loc = tuple(err["loc"])
        if drop_prefix and loc[: len(drop_prefix)] == drop_prefix:
            loc = loc[len(drop_prefix) :]
        # Drop pydantic's union-member tags (e.g. "inside") from the path.
        loc = tuple(p for p in loc if not (isinstance(p, str) and p in _UNION_TAGS))
        issues.append(PlanIssue(_loc_of(loc), str(err["msg"])))
    return issues


def parse_plan(data: Any) -> PlanRequest:
    """Validate the request's shape, turning pydantic's errors into located ``PlanIssue``s."""
    try:
        return PlanRequest.model_validate(data)
    except ValidationError as exc:
        raise PlanError(issues_from_errors(exc.errors(include_url=False))) from None


# A yaw goal's energy has sigma = tolerance / BOUND_SIGMAS (see the Yaw branch of the compiler).
BOUND_SIGMAS = 3.0
POUR_UPRIGHT_SIN = math.sin(math.radians(POUR_UPRIGHT_DEG))  # the upright factor's residual bound
HANDOVER_CLEARANCE = 0.10  # m between the giver's and the receiver's grasp points
HANDOVER_TOLERANCE = 0.01
REACH_TOLERANCE = 0.02  # m beyond PANDA_REACH at which the reach factor's energy is 1/2
# Objects placed on one target (implied ``apart`` and ``placed_inside`` on the place actions) and
# the plan's own ``apart``: PLACED_CLEARANCE between them and from the walls, with a sigma of
# APART_TOLERANCE, about a third of it as for goals (BOUND_SIGMAS). Executed placements land
# 4-9 mm off (the release, and earlier blocks' errors add up), so the plan needs more than the
# goal's 5 mm. With 6 mm at a 5 mm sigma the top-1 plans of Constrained Packing T3 (seeds 0-9,
# 32 candidates) overlapped by 2 mm (median of the closest pair); with 9 mm at 2 mm they keep
# 5.9 mm (scripts/placement_gaps.py; ADR 0010).
APART_TOLERANCE = 0.002  # m
PLACED_CLEARANCE = 0.009  # m
# The fingers placing a block (``fingers_clear``; their size: gfc.kinds.FINGER_THICKNESS): the
# release opens each finger 6 mm more (gfc.sim.skills.placing.RELEASE_TRAVEL), and
# FINGER_CLEARANCE leaves 2 mm beyond that.
FINGER_CLEARANCE = 0.008  # m
# A block's grasp point within GRASP_CENTRE_BAND of the pads' middle (``grasp_centred``).
GRASP_CENTRE_BAND = 0.01  # m
GRASP_CENTRE_TOLERANCE = 0.003  # m
# By a target without an opening (the rack): unchanged since session 12, measured at 100 trials.
RELEASED_CLEAR_TOLERANCE = 0.005  # m
RELEASED_CLEARANCE = 0.006  # m
STROKE_TOLERANCE = 0.01  # m: a stroked block ends within millimetres of the contact model
STROKE_TURN_MARGIN = math.radians(5.0)  # inside the screen's MAX_STROKE_TURN, for the factor
STROKE_MARGIN_GAIN = 4.0  # how much more the hook's margins (face, clearance) weigh than sliding
# m: a placed object that a stroke then moves rests where the place action put it. Tighter than
# the kinematic link's 2 cm settling slack: with 2 cm the block's node still sat 3-11 cm from
# the release in Rearrangement Push T2 (seed 0, 32 candidates), with 5 mm 1-3 cm.
REST_LINK_TOLERANCE = 0.005

_UNION_TAGS = {
    "apart",
    "inside",
    "aligned",
    "fixed_transform",
    "yaw",
    "near",
    "far",
    "function-after[_unit_quaternion(), list[float]]",
}


def load_plan(path: str | Path) -> PlanRequest:
    """Read a plan JSON file; a file that is not JSON is reported with its line and column."""
    text = Path(path).read_text()
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise PlanError([PlanIssue(f"{path}:{exc.lineno}:{exc.colno}", f"not JSON: {exc.msg}")]) from None
    return parse_plan(data)


@dataclass
class _State:
    """Book-keeping while walking the skeleton."""

    latest: dict[str, int] = field(default_factory=dict)  # entity -> node id
    holders: dict[str, set[str]] = field(default_factory=dict)  # object -> robots holding it
    holding: dict[str, str | None] = field(default_factory=dict)  # robot -> object held


def _nodes_by_token(tokens: list[FactorToken]) -> dict[tuple[str, str], int]:
    """A step factor's node ids by (role, phase)."""
    return {(t.role, t.phase): t.node for t in tokens if t.node is not None}


class _Compiler:
    def __init__(self, plan: PlanRequest) -> None:
        self.plan = plan
        self.issues: list[PlanIssue] = []
        self.nodes: list[NodeVersion] = []
        self.actions: list[ActionVariable] = []
        self.temporal: list[TemporalFactor] = []
        self.spatial: list[SpatialFactor] = []
        self.stages: list[tuple[int, ...]] = []
        self.terminal: list[tuple[int, str]] = []  # action-less steps without a learned factor
        self.robots = {r.name: r for r in plan.scene.robots}
        self.grasp_action: dict[str, int] = {}  # robot -> the action of the grasp it holds by
        self.resting: dict[str, list[tuple[str, int]]] = {}  # target -> (object, place action) left on it
        # A placed object's effect node -> (the target's pre node, the place action): the rest
        # link a stroke from that node adds (``add_stroke``).
        self.placed_by: dict[int, tuple[int, int]] = {}
        self.objects = {o.name: o for o in plan.scene.objects}
        self.state = _State()
        self.snapshots: list[dict[str, int]] = []  # entity -> node id after each stage
        self.stage_of_step: dict[int, int] = {}
        self.stage_of_group: dict[str, int] = {}
        self.versions: dict[str, int] = {}

    def error(self, loc: str, message: str) -> None:
        self.issues.append(PlanIssue(loc, message))

    # ------------------------------------------------------------------ scene
    def check_scene(self) -> None:
        seen: dict[str, str] = {}
        for i, r in enumerate(self.plan.scene.robots):
            if r.name in seen:
                self.error(f"scene.robots[{i}].name", f"name {r.name!r} is already used by {seen[r.name]}")
            seen[r.name] = f"scene.robots[{i}]"
        for i, o in enumerate(self.plan.scene.objects):
            if o.name in seen:
                self.error(f"scene.objects[{i}].name", f"name {o.name!r} is already used by {seen[o.name]}")
            seen[o.name] = f"scene.objects[{i}]"
            if o.kind not in OBJECT_KINDS:
                known = ", ".join(sorted(OBJECT_KINDS))
                self.error(f"scene.objects[{i}].kind", f"unknown object kind {o.kind!r} (known: {known})")

    def world_from_base(self, robot: str) -> np.ndarray:
        r = self.robots[robot]
        return pose7_to_matrix([*r.base, *yaw_quat(r.yaw)])

    def shoulder(self, robot: str) -> list[float]:
        """The arm's shoulder (joint 2) in the world: where its reach is measured from."""
        point = self.world_from_base(robot) @ np.array([0.0, 0.0, PANDA_SHOULDER_Z, 1.0])
        return [float(v) for v in point[:3]]

    def add_node(self, entity: str, known_value: np.ndarray | None, written_by: tuple[int, ...]) -> int:
        is_robot = entity in self.robots
        version = self.versions.get(entity, -1) + 1
        self.versions[entity] = version
        node = NodeVersion(
            id=len(self.nodes),
            entity=entity,
            version=version,
            entity_type="robot" if is_robot else "object",
            kind="robot" if is_robot else self.objects[entity].kind,
            dim=ROBOT_STATE_DIM if is_robot else OBJECT_STATE_DIM,
            known=known_value is not None,
            value=None if known_value is None else tuple(float(v) for v in known_value),
            written_by=written_by,
        )
        self.nodes.append(node)
        self.state.latest[entity] = node.id
        return node.id

    def initial_nodes(self) -> None:
        for name, r in self.robots.items():
            if r.ee_pose is not None:
                ee = pose7_to_pose9(r.ee_pose)
            else:
                ee = matrix_to_pose9(self.world_from_base(name) @ pose7_to_matrix(HOME_EE_POSE_IN_BASE))
            self.add_node(name, np.concatenate([ee, [r.gripper]]), ())
            self.state.holding[name] = None
        for name, o in self.objects.items():
            if o.kind in OBJECT_KINDS:
                self.add_node(name, pose7_to_pose9(o.pose), ())
            self.state.holders[name] = set()
        self.snapshots.append(dict(self.state.latest))

    # ------------------------------------------------------------------ skeleton
    def group_stages(self) -> list[list[int]]:
        stages: list[list[int]] = []
        closed: set[str] = set()
        for i, step in enumerate(self.plan.skeleton):
            g = step.group
            if g is not None and stages and self.plan.skeleton[stages[-1][0]].group == g:
                stages[-1].append(i)
                continue
            if g is not None and g in closed:
                self.error(
                    f"skeleton[{i}].group",
                    f"group {g!r} is split by other steps; steps of one group must be adjacent",
                )
            if g is not None:
                closed.add(g)
            stages.append([i])
        return stages

    def check_entities(self, i: int, step: Step, spec: SkillSpec) -> bool:
        ok = True
        loc = f"skeleton[{i}]"
        if step.robot not in self.robots:
            kind = "an object, not a robot" if step.robot in self.objects else "not in the scene"
            self.error(f"{loc}.robot", f"{step.robot!r} is {kind}")
            ok = False
        for field_name, value, want in (
            ("object", step.object, "object"),
            ("target", step.target, "object"),
            ("from", step.from_, "robot"),
        ):
            if value is None:
                continue
            pool = self.objects if want == "object" else self.robots
            if value not in pool:
                other = self.robots if want == "object" else self.objects
                what = (
                    f"a {'robot' if want == 'object' else 'object'}, not {'an object' if want == 'object' else 'a robot'}"
                    if value in other
                    else "not in the scene"
                )
                self.error(f"{loc}.{field_name}", f"{value!r} is {what}")
                ok = False
            elif want == "object" and self.objects[value].kind not in OBJECT_KINDS:
                ok = False  # already reported at scene level
        if spec.object_required and step.object is None:
            self.error(f"{loc}.object", f"skill {spec.name!r} needs an object")
            ok = False
        if spec.target_required and step.target is None:
            self.error(f"{loc}.target", f"skill {spec.name!r} needs a target")
            ok = False
        if spec.hands_over and step.from_ is None:
            self.error(f"{loc}.from", f"skill {spec.name!r} needs the robot that hands the object over")
            ok = False
        if not spec.target_required and step.target is not None:
            self.error(f"{loc}.target", f"skill {spec.name!r} takes no target")
            ok = False
        if not spec.hands_over and step.from_ is not None:
            self.error(f"{loc}.from", f"skill {spec.name!r} takes no 'from' robot")
            ok = False
        if ok and step.from_ == step.robot:
            self.error(f"{loc}.from", "a robot cannot hand an object over to itself")
            ok = False
        if ok and step.object is not None and step.object == step.target:
            self.error(f"{loc}.target", "object and target must differ")
            ok = False
        return ok

    def check_holding(self, i: int, step: Step, spec: SkillSpec, stage_steps: list[Step]) -> None:
        loc = f"skeleton[{i}]"
        held = self.state.holding.get(step.robot)
        obj = step.object
        if spec.requires_free and held is not None:
            self.error(
                f"{loc}.robot",
                f"robot {step.robot!r} already holds {held!r}; place or hand it over first",
            )
        if spec.grasps and not spec.hands_over and obj is not None:
            holders = self.state.holders.get(obj, set())
            if holders:
                who = ", ".join(sorted(holders))
                self.error(
                    f"{loc}.object",
                    f"{obj!r} is already held by {who}: an object cannot be picked twice without "
                    f"being released (use 'regrasp' with 'from' for a handover)",
                )
            o = self.objects[obj]
            if o.fixed:
                self.error(f"{loc}.object", f"{obj!r} is fixed to the world and cannot be picked")
            elif not OBJECT_KINDS[o.kind].graspable:
                self.error(f"{loc}.object", f"objects of kind {o.kind!r} cannot be grasped")
        giver = step.from_
        if spec.hands_over and obj is not None and giver is not None and self.state.holding.get(giver) != obj:
            actual = self.state.holding.get(giver)
            self.error(
                f"{loc}.from",
                f"robot {giver!r} does not hold {obj!r} (it holds {actual!r}) and cannot hand it over",
            )
        if spec.requires_held:
            if obj is None:
                if spec.name == "move" and held is not None:
                    self.error(
                        f"{loc}.object",
                        f"robot {step.robot!r} holds {held!r}, which moves with it: name it in 'object'",
                    )
            elif held != obj:
                self.error(
                    f"{loc}.object",
                    f"robot {step.robot!r} does not hold {obj!r} (it holds {held!r}); "
                    f"pick it or take it over first",
                )
            else:
                # An object held by several robots moves only if all of them act on it together.
                co_holders = self.state.holders.get(obj, set()) - {step.robot}
                in_stage = {s.robot for s in stage_steps if s.object == obj}
                missing = co_holders - in_stage
                if missing and spec.name != "pour":
                    self.error(
                        f"{loc}.object",
                        f"{obj!r} is also held by {', '.join(sorted(missing))}, which must act on it "
                        f"in the same group",
                    )

    def apply_holding(self, step: Step, spec: SkillSpec) -> None:
        obj = step.object
        if obj is None:
            return
        if spec.grasps:
            self.state.holding[step.robot] = obj
            self.state.holders.setdefault(obj, set()).add(step.robot)
        if spec.hands_over and step.from_ is not None:
            self.state.holding[step.from_] = None
            self.state.holders[obj].discard(step.from_)
        if spec.releases:
            self.state.holding[step.robot] = None
            self.state.holders[obj].discard(step.robot)

    def role_entity(self, step: Step, role: Role) -> str | None:
        return {
            "robot": step.robot,
            "object": step.object,
            "target": step.target,
            "from": step.from_,
        }[role]

    def compile_stage(self, stage: list[int]) -> None:
        steps = [self.plan.skeleton[i] for i in stage]
        valid: list[tuple[int, Step, SkillSpec]] = []
        robots_in_stage: dict[str, int] = {}
        for i, step in zip(stage, steps, strict=True):
            spec = SKILLS.get(step.skill)
            if spec is None:
                self.error(
                    f"skeleton[{i}].skill",
                    f"unknown skill {step.skill!r} (known: {', '.join(sorted(SKILLS))})",
                )
                continue
            if not self.check_entities(i, step, spec):
                continue
            for r in (step.robot, step.from_):
                if r is not None and r in robots_in_stage:
                    self.error(
                        f"skeleton[{i}].robot",
                        f"robot {r!r} already acts in step {robots_in_stage[r]} of the same group",
                    )
                elif r is not None:
                    robots_in_stage[r] = i
            self.check_holding(i, step, spec, steps)
            valid.append((i, step, spec))

        before = dict(self.state.latest)
        writers: dict[str, list[int]] = {}
        for i, step, spec in valid:
            with_object = step.object is not None
            for role in spec.writes:
                entity = self.role_entity(step, role)
                if entity is not None and (role != "object" or with_object):
                    writers.setdefault(entity, []).append(i)
        after = {entity: self.add_node(entity, None, tuple(ws)) for entity, ws in writers.items()}
        for entity, node in after.items():
            if entity in self.robots:
                self.add_reach(entity, node)

        for i, step, spec in valid:
            with_object = step.object is not None
            if spec.action_dim == 0 and not spec.writes:
                # A terminal skill (strike, pour) has nothing to sample and changes no node. A
                # strike's precondition is a geometric test, which a plan states as a constraint
                # (the hammer head aligned over the nail); a pour's also has a learned model of its
                # pre-state (where the arms can meet and tip; docs/adr/0006), a factor over its
                # pre nodes alone.
                self.add_preconditions(step)
                if not spec.learned_precondition:
                    self.apply_holding(step, spec)
                    self.terminal.append((i, spec.name))
                    continue
            tokens: list[FactorToken] = []
            action_id: int | None = None
            for token in spec.tokens(with_object=with_object):
                if token.phase == "action":
                    action_id = len(self.actions)
                    self.actions.append(ActionVariable(action_id, i, spec.action_names))
                    tokens.append(FactorToken("action", "action", token.dim, action=action_id))
                    continue
                entity = self.role_entity(step, token.role)  # type: ignore[arg-type]
                assert entity is not None
                table = before if token.phase == "pre" else after
                tokens.append(FactorToken(token.role, token.phase, token.dim, node=table[entity]))
            model = step.model or default_model_key(
                spec.name,
                self.objects[step.object].kind if step.object else None,
                self.objects[step.target].kind if step.target in self.objects else None,
            )
            if self.plan.options.kinematics:
                self.add_kinematics(spec, with_object, tokens, action_id)
            self.note_placement(spec, tokens, action_id)
            self.temporal.append(
                TemporalFactor(
                    step=i,
                    skill=spec.name,
                    model=model,
                    robot=step.robot,
                    group=step.group,
                    tokens=tuple(tokens),
                    world_from_model=tuple(
                        tuple(float(v) for v in row) for row in self.world_from_base(step.robot)
                    ),
                )
            )
            if spec.name in STROKE_SIGNS and action_id is not None:
                self.add_stroke(step, before, after, action_id)
            if spec.hands_over and action_id is not None and step.from_ in self.grasp_action:
                self.add_hands_apart(self.grasp_action[step.from_], action_id)
            if spec.grasps and action_id is not None:
                self.grasp_action[step.robot] = action_id
                self.add_grasp_centred(step, action_id)
            self.track_resting(step, spec, action_id, before.get(step.target or ""))
            self.apply_holding(step, spec)
        self.add_closed_chain(valid, before, after)
        stage_index = len(self.snapshots)
        for i in stage:
            self.stage_of_step[i] = stage_index
        group = steps[0].group
        if group is not None:
            self.stage_of_group[group] = stage_index
        self.stages.append(tuple(stage))
        self.snapshots.append(dict(self.state.latest))

    def add_kinematics(
        self, spec: SkillSpec, with_object: bool, tokens: list[FactorToken], action_id: int | None
    ) -> None:
        """The step's kinematic links (gfc/plan/kinematics.py) as implied spatial factors."""
        node_of = _nodes_by_token(tokens)
        for link in links_of(spec.name, with_object):
            nodes = [node_of.get(ref) for ref in link.nodes]
            if any(n is None for n in nodes) or (link.with_action and action_id is None):
                continue
            self.spatial.append(
                SpatialFactor(
                    link.type,
                    "implied",
                    len(self.spatial),
                    tuple(n for n in nodes if n is not None),
                    {"weight": 1.0, **link.params},
                    (action_id,) if link.with_action and action_id is not None else (),
                )
            )

    def add_preconditions(self, step: Step) -> None:
        """A pour's precondition that holds whatever the plan says: both containers upright
        (tilted less than POUR_UPRIGHT_DEG) when it starts. Without it the two move models of a
        pour meeting tilt the containers freely and about one candidate in eight failed on it
        alone (docs/adr/0005). Where the lip goes is the plan's to state (an ``aligned``)."""
        if step.skill != "pour":
            return
        for entity in (step.object, step.target):
            node = self.state.latest.get(entity) if entity is not None else None
            if node is None:
                continue
            params = {"weight": 1.0, "tolerance": POUR_UPRIGHT_SIN / BOUND_SIGMAS}
            self.spatial.append(SpatialFactor("upright", "implied", len(self.spatial), (node,), params))
        self.add_palm_clear(step)

    def add_palm_clear(self, step: Step) -> None:
        """The hand holding a pour's source is not between it and the target (``palm_clear``
        over the two containers' nodes and the source's grasp action: the hand's pose is the
        source's node carried by the grasp). The screen refuses such a pour (docs/adr/0013): every
        logged spill had it, and so did half of GFC's top-1 pours before this factor."""
        source, target = step.object, step.target
        grasp = self.grasp_action.get(step.robot)
        if source is None or target is None or grasp is None:
            return
        latest, objects = self.state.latest, self.objects
        if source not in latest or target not in latest or source not in objects or target not in objects:
            return
        kinds = [OBJECT_KINDS[objects[name].kind] for name in (source, target)]
        if not all("rim" in k.frames for k in kinds):
            return
        params = {
            "weight": 1.0,
            # The screen's bound, about a degree past side-on, is BOUND_SIGMAS tolerances away.
            "tolerance": abs(POUR_PALM_TOWARDS) / BOUND_SIGMAS,
            "source_frame": list(kinds[0].frame("rim")),
            "target_frame": list(kinds[1].frame("rim")),
        }
        nodes = (latest[source], latest[target])
        self.spatial.append(
            SpatialFactor("palm_clear", "implied", len(self.spatial), nodes, params, (grasp,))
        )

    def add_reach(self, robot: str, node: int) -> None:
        """Every hand pose a plan samples must be within the arm's reach of its shoulder. The
        skill models see one arm each, in its base frame; where two of them share a node (a
        hand-over: the giver's move and the receiver's regrasp, whose data had givers on both
        sides) the composition could put the giver's hand over the other arm's base, 1 m and more
        from its shoulder (half of Hammer Place's hand-over samples before this factor)."""
        params = {"weight": 1.0, "tolerance": REACH_TOLERANCE, "shoulder": self.shoulder(robot)}
        params["reach"] = PANDA_REACH
        self.spatial.append(SpatialFactor("reach", "implied", len(self.spatial), (node,), params))

    def add_stroke(self, step: Step, before: dict[str, int], after: dict[str, int], action: int) -> None:
        """A push or pull with a hook moves its target as the hook's geometry says: slid along
        the stroke by r less the gap closed first, caught only by the hook's face
        (``gfc.constraints.stroke``). The push and pull models learn that from a few hundred
        rows only roughly, and a goal on the stroked target (a block under the rack) then pulled
        their effect nodes where the stroke does not take the block: 0 of 32 GFC candidates of
        Rearrangement Push T1 left it under the rack in session 12, before this factor."""
        tool, target = step.object, step.target
        if tool is None or target is None or target not in after or target not in before:
            return
        tool_kind = OBJECT_KINDS[self.objects[tool].kind]
        if "tip" not in tool_kind.frames:
            return
        sign = STROKE_SIGNS[step.skill]
        low, high = hook_face_span(sign)
        params = {
            "weight": 1.0,
            "tolerance": STROKE_TOLERANCE,
            "sign": sign,
            "base": [float(v) for v in self.world_from_base(step.robot)[:3, 3]],
            "tip": [float(v) for v in tool_kind.frame("tip")[:3]],
            "bar_half_x": HOOK_TIP_BAR_HALF_X,
            "half_extents": list(OBJECT_KINDS[self.objects[target].kind].half_extents),
            "clearance": STROKE_CLEARANCE,
            # The stroke's length, which the clearance adds to, within what the executor makes.
            "max_length": MAX_STROKE,
            # A centimetre inside the face's ends: a block caught by its edge slips off.
            "lateral": [low + STROKE_TOLERANCE, high - STROKE_TOLERANCE],
            # At the tolerance alone the composed samples sat on the margins: 126 of 192 GFC
            # candidates of Hook Reach T3 (seeds 0-5) came down on the block, and 1 passed the
            # screen (session 20, /tmp probe; docs/adr/0009 addendum).
            "margin_gain": STROKE_MARGIN_GAIN,
            # Met more askew the hook catches the block's corner (gfc.kinds.MAX_STROKE_TURN); a
            # few degrees inside it, as the face's span is a tolerance inside its ends.
            "max_turn": MAX_STROKE_TURN - STROKE_TURN_MARGIN,
        }
        if sign < 0:
            # Half a tolerance clear of the shaft's edge: samples settle on a margin's edge.
            params["shaft_edge"] = HOOK_SHAFT_Y[1] + STROKE_TOLERANCE / 2
        nodes = (before[target], after[target])
        self.spatial.append(SpatialFactor("stroke", "implied", len(self.spatial), nodes, params, (action,)))
        self.add_rest_link(before[target])

    def note_placement(self, spec: SkillSpec, tokens: list[FactorToken], action: int | None) -> None:
        """Remember where a place step's object node comes to rest (for ``add_rest_link``)."""
        if spec.name != "place" or action is None:
            return
        node_of = _nodes_by_token(tokens)
        target, placed = node_of.get(("target", "pre")), node_of.get(("object", "effect"))
        if target is not None and placed is not None:
            self.placed_by[placed] = (target, action)

    def add_rest_link(self, node: int) -> None:
        """A stroke planned from where a place step left its target: that node is where the place
        action puts the object (``relative_pose`` in the target's frame, the kinematic link of
        gfc/plan/kinematics.py, here whatever ``options.kinematics`` says). The place model ties
        its effect node to its action only loosely, so the push, planned from the node, stopped
        short of the rack where the action had released the block elsewhere: in session 12 no
        candidate of 32 passed the screen in most Rearrangement Push T2 and T3 scenes, most of
        them for the goal (docs/adr/0009)."""
        placed = self.placed_by.get(node)
        if placed is None or self.plan.options.kinematics:  # with kinematics on it is there already
            return
        target, action = placed
        link = next(k for k in links_of("place", True) if k.type == "relative_pose")
        params = {"weight": 1.0, **link.params, "tolerance": REST_LINK_TOLERANCE}
        factor = SpatialFactor(link.type, "implied", len(self.spatial), (target, node), params, (action,))
        self.spatial.append(factor)

    def track_resting(
        self, step: Step, spec: SkillSpec, action: int | None, before_target: int | None = None
    ) -> None:
        """Objects placed on one target and left there: a later placement on the same target
        must not overlap them (``apart`` on the two place actions, both poses in the target's
        frame, so the factor binds what is executed; the plan's own constraints bind the nodes,
        which the actions follow only loosely). Without it a packing's place actions released
        blocks into their neighbours even where the end-state nodes kept apart."""
        for role in spec.writes:
            entity = self.role_entity(step, role)
            for target, resting in list(self.resting.items()):
                if entity == target:
                    del self.resting[target]
                else:
                    self.resting[target] = [(o, a) for o, a in resting if o != entity]
        if spec.name != "place" or action is None or step.object is None or step.target is None:
            return
        if step.target not in self.objects:
            return
        self.add_placed_inside(step.object, step.target, action)
        self.add_released_clear(step.object, step.target, action)
        self.add_placed_reach(step.robot, before_target, action)
        if not self.rests_flat(step.object, step.target):
            return
        for other, other_action in self.resting.get(step.target, []):
            params = {
                "weight": 1.0,
                "tolerance": APART_TOLERANCE,
                "clearance": PLACED_CLEARANCE,
                "object_half_extents": list(OBJECT_KINDS[self.objects[other].kind].half_extents),
                "target_half_extents": list(OBJECT_KINDS[self.objects[step.object].kind].half_extents),
            }
            actions = (other_action, action)
            self.spatial.append(SpatialFactor("apart", "implied", len(self.spatial), (), params, actions))
        self.add_fingers_clear(step, self.resting.get(step.target, []), action)
        self.resting.setdefault(step.target, []).append((step.object, action))

    def add_fingers_clear(self, step: Step, resting: list[tuple[str, int]], action: int) -> None:
        """The fingers placing a block keep clear of the blocks placed before it on the same
        target and of its walls (``fingers_clear`` on the place action, the grasp and the
        neighbours' place actions). Blocks and cubes only: the fingers close on their faces, and
        a quarter turn of the hand is the same grasp."""
        assert step.object is not None and step.target is not None
        grasp = self.grasp_action.get(step.robot)
        kind = OBJECT_KINDS[self.objects[step.object].kind]
        inner = OBJECT_KINDS[self.objects[step.target].kind].inner_half_extents
        if grasp is None or not kind.quarter_turn_symmetric or (not resting and inner is None):
            return
        neighbours = [OBJECT_KINDS[self.objects[o].kind].half_extents for o, _ in resting]
        params = {
            "weight": 1.0,
            "tolerance": APART_TOLERANCE,
            **fingers_clear_params(kind.half_extents, neighbours, inner, FINGER_CLEARANCE),
        }
        actions = (action, grasp, *(a for _, a in resting))
        self.spatial.append(SpatialFactor("fingers_clear", "implied", len(self.spatial), (), params, actions))

    def fits_inside(self, obj: str, container: str) -> bool:
        """Whether ``obj`` fits ``container``'s opening at any yaw (its footprint's diagonal)."""
        inner = OBJECT_KINDS[self.objects[container].kind].inner_half_extents
        hx, hy, _ = OBJECT_KINDS[self.objects[obj].kind].half_extents
        return inner is not None and math.hypot(hx, hy) <= min(inner[:2])

    def rests_flat(self, obj: str, target: str) -> bool:
        """Whether objects placed on ``target`` rest side by side on one surface, so that two of
        them cannot overlap: inside a container they fit in, or on a plain target. Not an object
        too big for a container (a lid rests on its rim; what is placed "in" it later lands on
        the lid), nor by a target one can also place on top of (the rack)."""
        kind = OBJECT_KINDS[self.objects[target].kind]
        if kind.inner_half_extents is not None:
            return self.fits_inside(obj, target)
        return not kind.release_outside

    def add_placed_reach(self, robot: str, target_node: int | None, action: int) -> None:
        """Where a place action releases the object (its pose in the target's frame, carried to
        the world by the target's node) is within the arm's reach of its shoulder. The reach
        factor binds the hand's node, which the place model ties to its action only loosely."""
        if target_node is None:
            return
        params = {
            "weight": 1.0,
            "tolerance": REACH_TOLERANCE,
            "shoulder": self.shoulder(robot),
            "reach": PANDA_REACH,
        }
        nodes = (target_node,)
        self.spatial.append(
            SpatialFactor("placed_reach", "implied", len(self.spatial), nodes, params, (action,))
        )

    def add_released_clear(self, obj: str, target: str, action: int) -> None:
        """An object placed by a target without an opening, that no hand reaches under (the
        rack), is released outside the target's box: beside it or on top. The place model for
        a block by the rack was trained on placements in front of and behind the bar, and its
        samples also fall between the two, under the bar (where the hand meets the bar: type 2);
        Rearrangement Push's goal pulled them there."""
        kind = OBJECT_KINDS[self.objects[target].kind]
        if not kind.release_outside:
            return
        params = {
            "weight": 1.0,
            "tolerance": RELEASED_CLEAR_TOLERANCE,
            "clearance": RELEASED_CLEARANCE,
            "object_half_extents": list(OBJECT_KINDS[self.objects[obj].kind].half_extents),
            "target_half_extents": list(kind.half_extents),
        }
        self.spatial.append(
            SpatialFactor("released_clear", "implied", len(self.spatial), (), params, (action,))
        )

    def add_placed_inside(self, obj: str, container: str, action: int) -> None:
        """An object placed into a container that it fits in whatever its yaw (its footprint's
        diagonal within the opening) is released with its footprint inside the walls: ``inside``
        on the place action (a pose in the container's frame). Released across a wall, a block
        popped out (type 3); the goal's ``inside`` binds the end-state node, not the action."""
        kind = OBJECT_KINDS[self.objects[container].kind]
        if kind.inner_half_extents is None or not self.fits_inside(obj, container):
            return
        params = {
            "weight": 1.0,
            "tolerance": APART_TOLERANCE,
            "object_kind": self.objects[obj].kind,
            "inner_half_extents": list(kind.inner_half_extents),
            "margin": PLACED_CLEARANCE,
        }
        self.spatial.append(
            SpatialFactor("placed_inside", "implied", len(self.spatial), (), params, (action,))
        )

    def add_grasp_centred(self, step: Step, action: int) -> None:
        """A block is grasped near the middle of the pads (``grasp_centred`` on the grasp
        action). Held off centre along them, it turns in the grip under its own weight and
        slides there on the way: in GFC's and the chain's Packing T3 top-1 plans at ``ccf15ec``,
        blocks grasped 1.5 cm or more off centre failed at that pick or the placement after it
        4.9 % of the time up to 2.5 cm (4 of 81) and 38 % beyond (5 of 13), the rest 1.0 %
        (11 of 1075). Blocks only, as the fingers' other checks: a handle is held anywhere
        along it."""
        if step.object is None or step.object not in self.objects:
            return
        if not OBJECT_KINDS[self.objects[step.object].kind].quarter_turn_symmetric:
            return
        params = {"weight": 1.0, "tolerance": GRASP_CENTRE_TOLERANCE, "band": GRASP_CENTRE_BAND}
        self.spatial.append(
            SpatialFactor("grasp_centred", "implied", len(self.spatial), (), params, (action,))
        )

    def add_hands_apart(self, giver_grasp: int, receiver_grasp: int) -> None:
        """At a hand-over both hands hold the object at once, so the receiver's grasp must
        leave room for the giver's hand: their grasp points, both actions in the object's frame
        (a carried object stays put in the hand, docs/adr/0002), at least HANDOVER_CLEARANCE
        apart. Without it the pick model's grasps (anywhere along a hammer's handle) and the
        regrasp model's were 3-5 cm apart, and the receiver's approach ran into the giver's
        hand. On actions, not robot nodes: the nodes follow the grasps only loosely."""
        params = {"weight": 1.0, "tolerance": HANDOVER_TOLERANCE, "distance": HANDOVER_CLEARANCE}
        actions = (giver_grasp, receiver_grasp)
        self.spatial.append(SpatialFactor("grasps_apart", "implied", len(self.spatial), (), params, actions))

    def add_closed_chain(
        self, valid: list[tuple[int, Step, SkillSpec]], before: dict[str, int], after: dict[str, int]
    ) -> None:
        """Two hands moving one object they both hold form a closed chain: their relative pose
        cannot change (the simulator refuses a group move that would pull them apart). That is
        physics, not a user's wish, so the compiler adds it as a spatial factor between the two
        robots' nodes before and after the stage, whatever constraints the plan states."""
        moves = [step for _, step, _ in valid if step.skill == "move" and step.object is not None]
        if len(valid) != 2 or len(moves) != 2 or moves[0].object != moves[1].object:
            return
        a, b = moves[0].robot, moves[1].robot
        if a not in after or b not in after:
            return
        params = {"weight": 1.0, "tolerance": 0.005, "transform": None}
        nodes = (before[a], before[b], after[a], after[b])
        self.spatial.append(SpatialFactor("fixed_transform", "implied", len(self.spatial), nodes, params))

    # ------------------------------------------------------------------ spatial factors
    def resolve_ref(self, ref: int | str, loc: str) -> int | None:
        """A reference -> index into ``self.snapshots``."""
        if isinstance(ref, int):
            if ref >= len(self.plan.skeleton):
                self.error(
                    loc,
                    f"step {ref} does not exist (the skeleton has {len(self.plan.skeleton)} steps, 0-{len(self.plan.skeleton) - 1})",
                )
                return None
            return self.stage_of_step.get(ref)
        if ref == "start":
            return 0
        if ref == "end":
            return len(self.snapshots) - 1
        if ref not in self.stage_of_group:
            groups = ", ".join(sorted(self.stage_of_group)) or "none"
            self.error(loc, f"no step or group {ref!r} (groups: {groups}; or 'start', 'end', a step index)")
            return None
        return self.stage_of_group[ref]

    def entity_node(self, snapshot: int, entity: str, loc: str) -> int | None:
        if entity not in self.robots and entity not in self.objects:
            self.error(loc, f"{entity!r} is not in the scene")
            return None
        return self.snapshots[snapshot].get(entity)

    def kind_frame(self, entity: str, frame: str | None, loc: str) -> tuple[float, ...] | None:
        if entity in self.robots:
            if frame is not None:
                self.error(loc, f"robots have no named frames (got {frame!r})")
                return None
            return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        kind = OBJECT_KINDS.get(self.objects[entity].kind)
        if kind is None:
            return None
        try:
            return kind.frame(frame)
        except KeyError as exc:
            self.error(loc, str(exc.args[0]))
            return None

    def compile_spatial(self, spec: SpatialFactorSpec, source: str, index: int) -> None:
        loc = f"{source}[{index}]"
        snapshots: list[int] = []
        for j, ref in enumerate(spec.refs()):
            ref_loc = f"{loc}.at" if not isinstance(spec.at, list) else f"{loc}.at[{j}]"
            snap = self.resolve_ref(ref, ref_loc)
            if snap is not None:
                snapshots.append(snap)
        if len(snapshots) != len(spec.refs()):
            return
        entities = [("object", spec.object)]
        target = getattr(spec, "target", None)
        if target is not None:
            entities.append(("target", target))
        for field_name, entity in entities:
            if entity not in self.robots and entity not in self.objects:
                self.error(f"{loc}.{field_name}", f"{entity!r} is not in the scene")
                return
        params: dict[str, Any] = {"weight": spec.weight}
        if isinstance(spec, Inside):
            kind = OBJECT_KINDS.get(self.objects[spec.target].kind) if spec.target in self.objects else None
            if kind is None or kind.inner_half_extents is None:
                self.error(
                    f"{loc}.target",
                    f"{spec.target!r} is not a container (open boxes, mugs, cups, pots are)",
                )
                return
            if spec.object not in self.objects:
                self.error(
                    f"{loc}.object",
                    f"{spec.object!r} is a robot; only objects go inside containers",
                )
                return
            params.update(
                object_kind=self.objects[spec.object].kind,
                inner_half_extents=list(kind.inner_half_extents),
                margin=spec.margin,
                tolerance=0.01,
            )
        elif isinstance(spec, Aligned):
            f1 = self.kind_frame(spec.object, spec.frame, f"{loc}.frame")
            f2 = self.kind_frame(spec.target, spec.target_frame, f"{loc}.target_frame")
            if f1 is None or f2 is None:
                return
            params.update(
                object_frame=list(f1),
                target_frame=list(f2),
                height=spec.height,
                offset=spec.offset,
                # A goal's tolerance is the bound the simulator checks (as a yaw's, below).
                tolerance=spec.tolerance / BOUND_SIGMAS if source == "goal" else spec.tolerance,
            )
        elif isinstance(spec, FixedTransform):
            if spec.transform is None and len(snapshots) < 2:
                self.error(
                    f"{loc}.at",
                    "fixed_transform needs two or more states in 'at', or a 'transform'",
                )
                return
            params.update(tolerance=spec.tolerance, transform=spec.transform)
        elif isinstance(spec, Yaw):
            # tolerance_deg is the pass bound the simulator checks; an energy with that as its
            # sigma misses it a third of the time (pot turns landed 5-9 degrees off, 13 of 96
            # top-1 trials). A third of it puts 99.7 % of the factor's mass inside the bound.
            params.update(
                yaw=math.radians(spec.yaw_deg), tolerance=math.radians(spec.tolerance_deg) / BOUND_SIGMAS
            )
        elif isinstance(spec, Near | Far):
            params.update(distance=spec.distance, tolerance=0.01)
        elif isinstance(spec, Apart):
            robots = [(f, e) for f, e in entities if e not in self.objects]
            if robots:
                self.error(f"{loc}.{robots[0][0]}", f"{robots[0][1]!r} is a robot; apart is between objects")
                return
            params.update(
                object_half_extents=list(OBJECT_KINDS[self.objects[spec.object].kind].half_extents),
                target_half_extents=list(OBJECT_KINDS[self.objects[spec.target].kind].half_extents),
                clearance=spec.clearance,
                tolerance=APART_TOLERANCE,
            )

        def nodes_at(snap: int) -> tuple[int, ...] | None:
            out = []
            for field_name, entity in entities:
                node = self.entity_node(snap, entity, f"{loc}.{field_name}")
                if node is None:
                    return None
                out.append(node)
            return tuple(out)

        groups: list[list[int]] = (
            [snapshots]
            if isinstance(spec, FixedTransform) and spec.transform is None
            else [[s] for s in snapshots]
        )
        for snaps in groups:
            nodes: list[int] = []
            for s in snaps:
                at = nodes_at(s)
                if at is None:
                    return
                nodes.extend(at)
            self.spatial.append(SpatialFactor(spec.type, source, index, tuple(nodes), dict(params)))  # type: ignore[arg-type]

    def run(self) -> CompiledPlan:
        self.check_scene()
        if self.issues:
            raise PlanError(self.issues)
        self.initial_nodes()
        for stage in self.group_stages():
            self.compile_stage(stage)
        for i, c in enumerate(self.plan.constraints):
            self.compile_spatial(c, "constraints", i)
        for i, g in enumerate(self.plan.goal):
            self.compile_spatial(g, "goal", i)
        if self.issues:
            raise PlanError(self.issues)
        return CompiledPlan(
            nodes=tuple(self.nodes),
            actions=tuple(self.actions),
            temporal=tuple(self.temporal),
            spatial=tuple(self.spatial),
            stages=tuple(self.stages),
            terminal=tuple(self.terminal),
        )


def compile_plan(plan: PlanRequest | dict[str, Any]) -> CompiledPlan:
    """Validate and compile; raises ``PlanError`` listing every problem with its location."""
    request = plan if isinstance(plan, PlanRequest) else parse_plan(plan)
    return _Compiler(request).run()


__all__ = ["PlanError", "PlanIssue", "compile_plan", "issues_from_errors", "load_plan", "parse_plan"]
