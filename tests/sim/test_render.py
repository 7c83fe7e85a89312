"""Headless rendering: a real picture of the scene, and key frames saved as PNGs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from gfc.plan.schema import PlanRequest
from gfc.sim.render import Camera, KeyFrames, render
from gfc.sim.world import World


def test_render_shows_the_table_and_the_robots(hammer_place_world: tuple[World, PlanRequest]) -> None:
    world, _ = hammer_place_world
    image = render(world)
    assert image.shape == (480, 640, 3) and image.dtype == np.uint8
    table = np.array([0.93, 0.9, 0.85]) * 255
    lower_middle = image[400, 320].astype(float)
    assert np.abs(lower_middle - table).max() < 60, lower_middle  # the table fills the foreground (lit)
    assert image[:200].std() > 20, "the upper half holds the robots, not a flat background"
    small = render(world, Camera(width=160, height=120))
    assert small.shape == (120, 160, 3)


def test_key_frames_are_written(hammer_place_world: tuple[World, PlanRequest], tmp_path: Path) -> None:
    world, _ = hammer_place_world
    frames = KeyFrames(Camera(width=160, height=120))
    frames.record(world, "start")
    frames.record(world, "again")
    paths = frames.save(tmp_path)
    assert [p.name for p in paths] == ["frame_00.png", "frame_01.png", "strip.png"]
    assert Image.open(paths[-1]).size == (160, 60)
