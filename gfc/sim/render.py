"""Headless pictures of the simulated world: one PNG of a state, or a strip of key frames."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pybullet as pb
from PIL import Image, ImageDraw

from gfc.sim.world import World

Rgb = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class Camera:
    """Looking at the workspace from in front of the robots, slightly above."""

    target: tuple[float, float, float] = (0.40, 0.0, 0.80)
    distance: float = 1.55
    yaw: float = 90.0  # degrees: PyBullet's yaw 90 looks along -x, back at the robots
    pitch: float = -30.0
    width: int = 640
    height: int = 480
    fov: float = 55.0


def render(world: World, camera: Camera = Camera()) -> Rgb:
    """RGB image (height, width, 3) of the physics client, with ER_TINY_RENDERER (no display)."""
    client = world.client
    view = pb.computeViewMatrixFromYawPitchRoll(
        list(camera.target),
        camera.distance,
        camera.yaw,
        camera.pitch,
        0.0,
        2,
        physicsClientId=client,
    )
    projection = pb.computeProjectionMatrixFOV(
        camera.fov, camera.width / camera.height, 0.05, 5.0, physicsClientId=client
    )
    _, _, rgba, _, _ = pb.getCameraImage(
        camera.width,
        camera.height,
        view,
        projection,
        renderer=pb.ER_TINY_RENDERER,
        lightDirection=[1.0, 0.5, 2.0],
        shadow=1,
        physicsClientId=client,
    )
    pixels = np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)
    return np.ascontiguousarray(pixels[:, :, :3])


def save_png(image: Rgb, path: str | Path, caption: str | None = None) -> Path:
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    picture = Image.fromarray(image)
    if caption:
        ImageDraw.Draw(picture).text((8, 8), caption, fill=(20, 20, 20))
    picture.save(out)
    return out


class KeyFrames:
    """Collects a captioned frame after each stage (pass ``record`` as ``on_stage``)."""

    def __init__(self, camera: Camera = Camera()) -> None:
        self.camera = camera
        self.frames: list[tuple[str, Rgb]] = []

    def record(self, world: World, caption: str) -> None:
        self.frames.append((caption, render(world, self.camera)))

    def save(self, folder: str | Path, columns: int = 4) -> list[Path]:
        """One PNG per frame (``frame_00.png``...) and ``strip.png``, all frames in a grid."""
        out = Path(folder)
        out.mkdir(parents=True, exist_ok=True)
        paths = [save_png(img, out / f"frame_{i:02d}.png", cap) for i, (cap, img) in enumerate(self.frames)]
        if self.frames:
            paths.append(
                save_strip(
                    [img for _, img in self.frames],
                    [c for c, _ in self.frames],
                    out / "strip.png",
                    columns,
                )
            )
        return paths


def save_strip(images: Sequence[Rgb], captions: Sequence[str], path: str | Path, columns: int = 4) -> Path:
    """Tile frames (halved) into one captioned grid image."""
    thumbs = [Image.fromarray(img).reduce(2) for img in images]
    w, h = thumbs[0].size
    rows = (len(thumbs) + columns - 1) // columns
    sheet = Image.new("RGB", (w * min(columns, len(thumbs)), h * rows), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for i, (thumb, caption) in enumerate(zip(thumbs, captions, strict=True)):
        x, y = (i % columns) * w, (i // columns) * h
        sheet.paste(thumb, (x, y))
        draw.text((x + 5, y + 5), caption, fill=(10, 10, 10))
    sheet.save(Path(path))
    return Path(path)
