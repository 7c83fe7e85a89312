"""The kinematic screen: what the simulator executes passes it; what the arms cannot reach, or a
terminal step whose precondition fails, does not; the ranking puts passing candidates first."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gfc.geometry import FloatArray, matrix_to_pose9, pose9_to_matrix
from gfc.kinds import PANDA_REACH, PANDA_SHOULDER_Z
from gfc.sim import screen as screen_module
from gfc.sim.execute import execute_plan
from gfc.sim.screen import Screen, Verdict, screen_order
from gfc.sim.skills import tools
from gfc.sim.skills.motions import translated
from gfc.tasks import SINGLE_ARM, TASKS, sample_task

SCENES = 4


def _reference(task: str, seed: int) -> list[FloatArray | None]:
    return [
        None if a is None else np.asarray(a, dtype=np.float64)
        for a in sample_task(task, seed).reference_actions
    ]


def _step_of(task: str, skill: str, obj: str | None = None) -> int:
    skeleton = sample_task(task, 0).plan.skeleton
    return next(i for i, s in enumerate(skeleton) if s.skill == skill and (obj is None or s.object == obj))


@pytest.mark.slow
@pytest.mark.parametrize("task", sorted(TASKS) + sorted(SINGLE_ARM))
def test_the_reference_parameters_pass(task: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """They succeed in the simulator (tests/sim/test_tasks.py), so the screen must let them by.
    Every hand pose they ask for is also within the planner's reach factor (PANDA_REACH from the
    shoulder): the compiler's implied reach factors never push against a working plan."""
    distances: list[float] = []
    real_reach = Screen._reach

    def measured(
        self: Screen, state: object, i: int, robot: str, pose: FloatArray, *a: object, **k: object
    ) -> None:
        shoulder = self.world.mirror.robots[robot].world_from_base @ np.array(
            [0.0, 0.0, PANDA_SHOULDER_Z, 1.0]
        )
        distances.append(float(np.linalg.norm(pose[:3, 3] - shoulder[:3])))
        real_reach(self, state, i, robot, pose, *a, **k)  # type: ignore[arg-type]

    monkeypatch.setattr(Screen, "_reach", measured)
    for seed in range(SCENES):
        with Screen(sample_task(task, seed).plan, seed) as screen:
            verdict = screen.check(_reference(task, seed))
        assert verdict.feasible, (seed, verdict)
    assert distances and max(distances) < PANDA_REACH, max(distances)


def test_a_grasp_whose_straight_approach_dead_ends_fails_there(monkeypatch: pytest.MonkeyPatch) -> None:
    """As the executor, the screen wants a pre-grasp solution from which the straight approach can
    be tracked; when no line can be, the first grasp fails with that reason."""
    monkeypatch.setattr(screen_module, "tracks_lines", lambda *args, **kwargs: False)
    with Screen(sample_task("hammer_place", 0).plan) as screen:
        verdict = screen.check(_reference("hammer_place", 0))
    assert not verdict.feasible
    assert verdict.step == 0
    assert "no straight line onwards from any free IK solution for the pre-grasp of lid" in verdict.reason


def _screen_shifted(task: str, step: int, axis: int, by: float) -> Verdict:
    """Screen the reference of scene 0 with one action value of one step shifted."""
    actions = _reference(task, 0)
    changed = actions[step]
    assert changed is not None
    changed = changed.copy()
    changed[axis] += by
    actions[step] = changed
    with Screen(sample_task(task, 0).plan) as screen:
        return screen.check(actions)


def test_a_move_target_out_of_reach_fails_at_that_step() -> None:
    move = _step_of("hammer_place", "move", "hammer")
    verdict = _screen_shifted("hammer_place", move, 0, 1.5)  # 1.5 m further out: no arm reaches it
    assert not verdict.feasible
    assert verdict.step == move
    assert "out of reach for the move target" in verdict.reason


def test_a_move_target_near_the_edge_of_reach_is_searched_and_fails() -> None:
    """30 cm further out passes the quick reach test but has no IK solution."""
    move = _step_of("hammer_place", "move", "hammer")
    verdict = _screen_shifted("hammer_place", move, 0, 0.45)
    assert not verdict.feasible
    assert verdict.step == move
    assert "no IK solution for the move target" in verdict.reason


def test_a_pour_the_arm_cannot_follow_fails_at_the_pour(monkeypatch: pytest.MonkeyPatch) -> None:
    """The reference passes; the same tipping motion carried 1.5 m up cannot be followed from
    any IK branch, so the screen rejects the pour (as the executor would, type 1)."""
    real = screen_module.tipping_poses

    def lifted(*args: object, **kwargs: object) -> list[FloatArray]:
        poses = real(*args, **kwargs)  # type: ignore[arg-type]
        return [poses[0]] + [translated(p, [0.0, 0.0, 1.5]) for p in poses[1:]]

    monkeypatch.setattr(screen_module, "tipping_poses", lifted)
    with Screen(sample_task("pour_cup", 0).plan) as screen:
        verdict = screen.check(_reference("pour_cup", 0))
    assert not verdict.feasible
    assert verdict.step == _step_of("pour_cup", "pour")
    assert "cannot tip mug over cup" in verdict.reason


def test_a_mug_lowered_into_the_cup_fails_at_the_meeting() -> None:
    """Both moves reachable, but the mug ends 10 cm lower than the reference puts it: inside the
    cup the other hand holds. Two carried objects are both static on the planning mirror, where
    Bullet reports no contact between them; until session 20 only the pour's own precondition
    (the source's bottom above the target's rim, tests/sim/test_pour_palm.py) caught this."""
    verdict = _screen_shifted("pour_cup", _step_of("pour_cup", "move", "mug"), 2, -0.10)
    assert not verdict.feasible
    assert verdict.step == _step_of("pour_cup", "move", "mug")
    assert "mug with cup" in verdict.reason


def test_a_grasp_beside_the_object_fails_because_the_fingers_would_miss() -> None:
    """The pot reference grasps its handle; 8 cm further out along the pot's y (the fingers'
    closing direction) the open fingers straddle only air. (At 6 cm one of them comes down on
    the pot: the landing check of ADR 0011 says so first.)"""
    verdict = _screen_shifted("pot_reorientation", 0, 1, 0.08)
    assert not verdict.feasible
    assert verdict.step == 0
    assert "the fingers would miss pot" in verdict.reason


def test_a_grasp_whose_open_finger_comes_down_on_the_block_fails_at_the_grasp() -> None:
    """A block grasped 2 cm off its centre along the fingers: the open finger (4 cm out) is
    5 mm inside the block's side, so the hand would land on the block's top (ADR 0011); 6 mm
    off, it comes down beside it and closes on it."""
    pick = _step_of("constrained_packing_t1", "pick")
    verdict = _screen_shifted("constrained_packing_t1", pick, 1, 0.02)
    assert not verdict.feasible
    assert verdict.step == pick
    assert "the open fingers would come down on block_0" in verdict.reason
    assert _screen_shifted("constrained_packing_t1", pick, 1, 0.006).feasible


@pytest.mark.parametrize(("lateral", "refused"), [(0.026, True), (-0.026, True), (0.02, False)])
def test_a_block_grasped_past_its_edge_along_the_pads_is_refused(lateral: float, refused: bool) -> None:
    """The reference grasp comes from above with the pads across the block's x: 2.6 cm along
    them from the centre of a 5 cm block is past its edge; 2 cm is on its face."""
    pick = _step_of("constrained_packing_t1", "pick")
    verdict = _screen_shifted("constrained_packing_t1", pick, 0, lateral)
    assert verdict.feasible is not refused
    if refused:
        assert verdict.step == pick
        assert "past its edge" in verdict.reason


def test_missing_actions_are_infeasible_and_wrong_lengths_are_errors() -> None:
    task = "pot_reorientation"
    actions = _reference(task, 0)
    with Screen(sample_task(task, 0).plan) as screen:
        actions[0] = None
        assert not screen.check(actions).feasible
        with pytest.raises(ValueError, match="actions for"):
            screen.check(actions[:-1])


def test_screen_order_puts_passing_candidates_first_in_their_order() -> None:
    task = "hammer_place"
    good = _reference(task, 0)
    bad = list(good)
    move = _step_of(task, "move", "hammer")
    assert good[move] is not None
    bad[move] = good[move] + np.array([1.5, 0, 0, 0, 0, 0, 0, 0, 0])
    order, verdicts = screen_order(sample_task(task, 0).plan, [bad, good, bad, good], keep=1)
    assert order == [1, 0, 2, 3]
    assert verdicts[0] is not None and not verdicts[0].feasible
    assert verdicts[1] is not None and verdicts[1].feasible
    assert verdicts[2] is None and verdicts[3] is None  # screening stopped after one pass


def test_a_pull_that_misses_the_block_with_the_hooks_face_fails_at_the_pull() -> None:
    """The tip 6 cm further to the block's -y side: the block's centre lies beyond the end of the
    hook's bar, which would sweep past it (the simulator reports type 3: not moved)."""
    pull = _step_of("hook_reach_t1", "pull")
    verdict = _screen_shifted("hook_reach_t1", pull, 1, -0.06)
    assert not verdict.feasible
    assert verdict.step == pull
    assert "off the hook's face" in verdict.reason


def test_the_steps_after_a_pull_are_screened() -> None:
    """Screening used to stop at the first stroke; now the hook's placement on the rack, after
    the pull, is checked too (here 60 cm above the rack: out of reach)."""
    place = _step_of("hook_reach_t1", "place", "hook")
    verdict = _screen_shifted("hook_reach_t1", place, 2, 0.6)
    assert not verdict.feasible
    assert verdict.step == place


def test_a_push_that_stops_short_fails_on_the_goal() -> None:
    """Every pose reachable, but a push 8 cm shorter leaves the block outside the goal's 4 cm:
    the end state is checked on the walked poses (the block slid by the contact model)."""
    push = _step_of("rearrangement_push_t1", "push")
    verdict = _screen_shifted("rearrangement_push_t1", push, 2, -0.08)
    assert not verdict.feasible
    assert verdict.step is None
    assert "the goal would not hold: aligned(block, rack)" in verdict.reason


def test_a_push_that_leaves_the_block_just_inside_the_goal_passes_as_marginal() -> None:
    """3.7 cm from the rack's centre (4 allowed) passes, marked marginal: within GOAL_MARGIN of
    the edge, where the contact model's millimetres decide; 2 cm passes with room to spare."""
    push = _step_of("rearrangement_push_t1", "push")
    edge = _screen_shifted("rearrangement_push_t1", push, 2, -0.037)
    assert edge.feasible and edge.marginal
    assert "the goal holds by less than 0.5 cm: aligned(block, rack): 3.7 cm" in edge.reason
    roomy = _screen_shifted("rearrangement_push_t1", push, 2, -0.02)
    assert roomy.feasible and not roomy.marginal


@pytest.mark.parametrize(
    ("grasp_turn", "gap", "doubt"),
    [(0, 0.009, False), (90, 0.009, False), (45, 0.009, True), (45, 0.04, False)],
)
def test_fingers_that_no_turn_of_the_hand_keeps_off_a_neighbour_make_a_placement_marginal(
    grasp_turn: float, gap: float, doubt: bool
) -> None:
    """Packing T1's second block placed ``gap`` beside the first along the box's x. Fingers that
    close along y pass by the neighbour; closing along x they would reach 16 mm into it, but the
    executor turns the hand a quarter (a block is the same block turned), so neither is in doubt.
    A grasp 45 degrees off the faces closes on the corners whichever the turn: at 9 mm the
    fingers reach into the neighbour and the candidate passes as marginal; 4 cm leaves room."""
    task = "constrained_packing_t1"
    actions = _reference(task, 0)
    pick = actions[2]
    assert pick is not None
    turn = np.eye(4)
    c, s = math.cos(math.radians(grasp_turn)), math.sin(math.radians(grasp_turn))
    turn[:2, :2] = [[c, -s], [s, c]]
    actions[2] = matrix_to_pose9(turn @ pose9_to_matrix(pick))
    # Both in the box's middle row, away from its walls: the first at x = -6 cm; the other two
    # blocks at the far end.
    verdict = _packing_t1_placed(actions, ((-0.06, 0.0), (-0.01 + gap, 0.0), (0.105, -0.055), (0.105, 0.055)))
    assert verdict.feasible, verdict
    assert ("step 3: the fingers on block_1 would reach" in verdict.reason) == doubt, verdict


def _packing_t1_placed(actions: list[FloatArray | None], slots: tuple[tuple[float, float], ...]) -> Verdict:
    """Screen Packing T1 scene 0 with its four blocks placed at ``slots`` (box frame x, y)."""
    for step, (x, y) in zip((1, 3, 5, 7), slots, strict=True):
        action = actions[step]
        assert action is not None
        action = action.copy()
        action[0], action[1] = x, y
        actions[step] = action
    with Screen(sample_task("constrained_packing_t1", 0).plan) as screen:
        return screen.check(actions)


@pytest.mark.parametrize(("gap", "refused"), [(-0.001, True), (0.001, False)])
def test_a_block_released_into_its_neighbour_is_refused(gap: float, refused: bool) -> None:
    """The descent is vertical: a footprint 1 mm into the neighbour's comes down on its top edge
    (placements planned that way failed at 28 %, scripts/placement_failures.py). Side by side
    along the box's y, where the fingers (closing along the box's x) pass the neighbour by."""
    actions = _reference("constrained_packing_t1", 0)
    verdict = _packing_t1_placed(
        actions, ((-0.06, -0.03), (-0.06, 0.02 + gap), (0.105, -0.055), (0.105, 0.055))
    )
    assert verdict.feasible != refused, verdict
    if refused:
        assert verdict.step == 3
        assert "block_1 released 0.1 cm into block_0" in verdict.reason


def test_screen_order_puts_marginal_passes_after_clear_ones() -> None:
    task = "rearrangement_push_t1"
    push = _step_of(task, "push")
    good = _reference(task, 0)
    edge = list(good)
    assert good[push] is not None
    edge[push] = good[push] + np.array([0.0, 0.0, -0.037, 0.0])
    plan = sample_task(task, 0).plan
    order, verdicts = screen_order(plan, [edge, good, edge, good], keep=1)
    assert order == [1, 0, 2, 3]  # the clear pass first; screening stopped at it
    assert verdicts[0] is not None and verdicts[0].marginal
    assert verdicts[2] is None and verdicts[3] is None
    # Marginal passes alone: screening stops at keep * MARGINAL_KEEP of them, in their order.
    order, verdicts = screen_order(plan, [edge] * 4, keep=1)
    assert order == [0, 1, 2, 3]
    assert [v is not None for v in verdicts] == [True] * screen_module.MARGINAL_KEEP + [False] * (
        4 - screen_module.MARGINAL_KEEP
    )


@pytest.mark.slow
@pytest.mark.parametrize("task", ["hook_reach_t1", "rearrangement_push_t1"])
def test_where_the_screen_slides_a_stroked_block_is_where_the_simulator_leaves_it(
    task: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The contact model's prediction against physics, for the tasks' reference strokes (the
    simulator moves the block only through the hook's contact)."""
    predicted: dict[int, FloatArray] = {}
    real_stroke = Screen._stroke

    def recorded(self: Screen, state: object, i: int, step: object, action: FloatArray) -> None:
        real_stroke(self, state, i, step, action)  # type: ignore[arg-type]
        predicted[i] = state.poses["block"].copy()  # type: ignore[attr-defined]

    monkeypatch.setattr(Screen, "_stroke", recorded)
    instance = sample_task(task, 0)
    with Screen(instance.plan) as screen:
        assert screen.check(_reference(task, 0)).feasible
    outcome = execute_plan(instance.plan, _reference(task, 0), seed=0)
    assert outcome.success, outcome
    (stroke,) = predicted
    actual = np.asarray(outcome.steps[stroke].poses["block"][:2])
    assert np.linalg.norm(predicted[stroke][:2, 3] - actual) < 0.01


def test_a_grasp_whose_hand_meets_a_fixture_fails_at_the_grasp() -> None:
    """The obstacle in front of the rack, grasped with the hand turned 90 degrees: the hand's
    width (across the fingers) reaches the bar. The straight descent may touch the object, not
    the rack: in the simulator the hand knocked the block away (fingers closed on nothing)."""
    task = "rearrangement_push_t2"
    actions = _reference(task, 0)
    grasp = actions[0]
    assert grasp is not None
    turned = np.eye(4)
    turned[:2, :2] = [[0.0, -1.0], [1.0, 0.0]]
    actions[0] = matrix_to_pose9(turned @ pose9_to_matrix(grasp))
    with Screen(sample_task(task, 0).plan) as screen:
        assert screen.check(_reference(task, 0)).feasible
        verdict = screen.check(actions)
    assert not verdict.feasible
    assert verdict.step == 0
    assert "collides (right with rack) for the grasp of obstacle_0" in verdict.reason


# GFC's top-1 plan for Hook Reach T2, seed 6 (log docs/bench/trials/single_arm_s19.jsonl): the
# pull turns the hook 49 degrees off the approach line, across the box, and the simulator
# reported type 3 ("the hook did not move the block (0.0 cm)"): the hook's shaft came down on
# the box's wall and the hand stopped 7 cm above the working height.
_HOOK_ACROSS_THE_BOX = [
    [-0.013221, -0.045925, 0.022993, 0.994567, -0.104065, 0.002496, -0.104067, -0.99457, 0.000635],
    [0.064538, -0.021694, 0.112369, -0.851055],
    [0.048104, -0.031301, 0.122996, -0.007877, -0.999969, -0.000197, 0.999969, -0.007877, -4e-06],
    [-0.003621, 0.002554, 0.033389, -0.170297, -0.985393, -0.000195, -0.985364, 0.170293, -0.007655],
    [0.017673, 0.001334, 0.015104, -0.991066, 0.133375, -0.000402, -0.133375, -0.991066, -0.000328],
]


def test_a_pull_whose_hook_comes_down_on_the_box_fails_at_the_pull(monkeypatch: pytest.MonkeyPatch) -> None:
    """The held hook against a fixed object: every object on the planning mirror is static, and
    Bullet reports no contact between two static bodies, so until session 20 the screen passed
    this pull; the held tool is now checked against objects by closest points. (This pull also
    meets the block 43 degrees askew, which the contact model now refuses first: that bound is
    lifted here to reach the collision check.)"""
    monkeypatch.setattr(tools, "MAX_STROKE_TURN", math.pi / 4)
    instance = sample_task("hook_reach_t2", 6)
    with Screen(instance.plan, 6) as screen:
        verdict = screen.check([np.asarray(a) for a in _HOOK_ACROSS_THE_BOX])
        assert screen.check(_reference("hook_reach_t2", 6)).feasible
    assert not verdict.feasible
    assert verdict.step == _step_of("hook_reach_t2", "pull")
    assert "(hook with box) for the working height" in verdict.reason


@pytest.mark.slow
def test_the_pull_the_screen_rejects_does_not_move_the_block_in_the_simulator() -> None:
    """The same plan executed: the pull fails, type 3, as logged."""
    instance = sample_task("hook_reach_t2", 6)
    outcome = execute_plan(instance.plan, [np.asarray(a) for a in _HOOK_ACROSS_THE_BOX], seed=6)
    pull = outcome.steps[_step_of("hook_reach_t2", "pull")]
    assert not pull.success
    assert "did not move the block" in pull.reason


def test_a_blow_that_would_come_down_on_the_hand_holding_the_nail_is_refused() -> None:
    """The reference holds the nail low (4.5 cm up its 8 cm); held 3 cm higher, the hand reaches
    above the nail's top and the hammer's head would land on it before the nail (the "blow
    missed the nail" failures of ADR 0017)."""
    pick_nail = _step_of("hammer_nail", "pick", "nail")
    verdict = _screen_shifted("hammer_nail", pick_nail, 2, 0.03)
    assert not verdict.feasible
    assert verdict.step == _step_of("hammer_nail", "strike")
    assert "the blow would meet something besides the nail" in verdict.reason
