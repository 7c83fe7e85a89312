"""PyBullet simulation of a bimanual Franka Panda: world, objects, skill executors, rendering.

Entry points::

    from gfc.sim import build_world, execute_plan, execute_in_world, goal_satisfied
    outcome = execute_plan(plan, actions, seed=0)          # builds and closes its own world
    with build_world(plan.scene) as world:                 # or keep a world to inspect/render
        outcome = execute_in_world(world, plan, actions, seed=0)

See docs/sim.md for what every skill's action means and how success is judged.
"""

from gfc.sim.execute import default_contents, execute_in_world, execute_plan, stages
from gfc.sim.goals import check_predicate, goal_satisfied
from gfc.sim.outcome import FailureType, PlanOutcome, SkillFailure, StepOutcome, StepTimings
from gfc.sim.render import Camera, KeyFrames, render, save_png
from gfc.sim.world import World, build_world, entity_poses, gripper_openings

__all__ = [
    "Camera",
    "FailureType",
    "KeyFrames",
    "PlanOutcome",
    "SkillFailure",
    "StepOutcome",
    "StepTimings",
    "World",
    "build_world",
    "check_predicate",
    "default_contents",
    "entity_poses",
    "execute_in_world",
    "execute_plan",
    "goal_satisfied",
    "gripper_openings",
    "render",
    "save_png",
    "stages",
]
