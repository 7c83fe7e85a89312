"""Example plans shipped with the package (``gfc/examples/*.json``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

EXAMPLES_DIR = Path(__file__).parent


def example_path(name: str) -> Path:
    path = EXAMPLES_DIR / f"{name}.json"
    if not path.is_file():
        known = ", ".join(sorted(p.stem for p in EXAMPLES_DIR.glob("*.json")))
        raise FileNotFoundError(f"no example plan {name!r} (known: {known})")
    return path


def load_example(name: str) -> dict[str, Any]:
    data: dict[str, Any] = json.loads(example_path(name).read_text())
    return data
