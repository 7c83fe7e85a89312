"""PlanBuilder writes plans that the service's own schema and compiler accept."""

from __future__ import annotations

from typing import Any

import pytest
from gfc_client import PlanBuilder

from gfc.examples import load_example
from gfc.plan import compile_plan
from gfc.plan.schema import PlanRequest


def two_arms() -> PlanBuilder:
    return PlanBuilder().robot("left", base=(0.0, 0.35, 0.625)).robot("right", base=(0.0, -0.35, 0.625))


def canonical(plan: dict[str, Any]) -> dict[str, Any]:
    return PlanRequest.model_validate(plan).to_json_dict()


def test_hammer_place_as_a_chain_equals_the_example() -> None:
    plan = (
        two_arms()
        .object("hammer", kind="hammer", pose=(0.45, 0.25, 0.64))
        .object("box", kind="box", pose=(0.45, -0.40, 0.625), fixed=True)
        .pick("left", "hammer")
        .move("left", "hammer")
        .handover("hammer", giver="left", receiver="right")
        .place("right", "hammer", target="box")
        .goal.inside("hammer", "box")
        .options(candidates=10, top_k=5, steps=50, seed=0)
        .build()
    )
    assert canonical(plan) == canonical(load_example("hammer_place"))
    compile_plan(PlanRequest.model_validate(plan))


def test_hammer_nail_with_a_group_and_constraints_equals_the_example() -> None:
    b = two_arms()
    for name, kind, pose in [
        ("box_hammer", "box", (0.50, 0.30, 0.625)),
        ("box_cube", "box", (0.30, 0.55, 0.625)),
        ("box_spare", "box", (0.30, 0.05, 0.625)),
    ]:
        b.object(name, kind=kind, pose=pose, fixed=True)
    b.object("lid", kind="lid", pose=(0.50, 0.30, 0.725)).object(
        "cube", kind="cube", pose=(0.30, 0.55, 0.635)
    )
    b.object("hammer", kind="hammer", pose=(0.50, 0.30, 0.635)).object(
        "nail", kind="nail", pose=(0.60, 0.10, 0.625)
    )
    for thing in ("lid", "cube"):
        b.pick("left", thing).place("left", thing, target="box_spare")
    b.pick("left", "hammer").move("left", "hammer").handover("hammer", giver="left", receiver="right")
    b.pick("left", "nail")
    with b.group("align"):
        b.move("left", "nail").move("right", "hammer")
    b.step("strike", "right", "hammer", target="nail")
    b.constraint.aligned("hammer", "nail", frame="head", target_frame="top", height=0.05, at="align")
    b.constraint.far("left", "right", 0.15, at="align")
    plan = b.build()
    assert canonical(plan) == canonical(load_example("hammer_nail"))
    compiled = compile_plan(PlanRequest.model_validate(plan))
    assert len(compiled.temporal) == 10 and compiled.terminal == ((10, "strike"),)  # strike: no factor


def test_every_factor_helper_validates() -> None:
    b = (
        two_arms()
        .object("cup", kind="cup", pose=(0.4, 0.1, 0.65, 0, 0, 0, 1))
        .object("bowl", kind="bowl", pose=(0.4, -0.2, 0.625), fixed=True)
    )
    b.pick("left", "cup", model="pick.cup@2").move("left", "cup", group="carry")
    b.constraint.near("cup", "bowl", 0.3, at=["carry", "end"]).constraint.yaw("cup", 90.0, tolerance_deg=10)
    b.constraint.fixed_transform("left", "cup", at=[0, 1], tolerance=0.02)
    b.goal.add("far", object="cup", target="right", distance=0.2, weight=2.0)
    plan = PlanRequest.model_validate(b.build())
    assert [c.type for c in plan.constraints] == ["near", "yaw", "fixed_transform"]
    assert plan.skeleton[0].model == "pick.cup@2" and plan.skeleton[1].group == "carry"
    assert plan.goal[0].weight == 2.0


def test_mistakes_fail_at_once_and_say_what_to_do() -> None:
    b = two_arms().object("hammer", kind="hammer", pose=(0.4, 0.2, 0.64))
    with pytest.raises(ValueError, match=r"skeleton\[0\].robot: no robot named 'lft'.*add it with .robot"):
        b.pick("lft", "hammer")
    with pytest.raises(ValueError, match=r"no object named 'hamer'"):
        b.pick("left", "hamer")
    with pytest.raises(ValueError, match="already in the scene"):
        b.object("left", kind="box", pose=(0, 0, 0))
    with pytest.raises(ValueError, match=r"\[x, y, z\] or \[x, y, z, qx, qy, qz, qw\]"):
        b.object("box", kind="box", pose=(0, 0))
    with pytest.raises(ValueError, match="at least one step"):
        b.build()
    with b.group("g"), pytest.raises(ValueError, match="do not nest"), b.group("h"):
        pass


def test_build_returns_a_fresh_copy() -> None:
    b = two_arms().object("hammer", kind="hammer", pose=(0.4, 0.2, 0.64)).pick("left", "hammer")
    first = b.build()
    first["skeleton"].clear()
    assert len(b.build()["skeleton"]) == 1
