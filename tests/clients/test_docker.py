"""docker/: the compose file validates with a real compose CLI, and every command that the image
and compose run is a command the ``gfc`` CLI really has (with those options)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from gfc.planner.library import InMemoryLibrary
from service.settings import Settings
from tests.service.conftest import running_server

ROOT = Path(__file__).resolve().parents[2]
DOCKERFILE = ROOT / "docker" / "Dockerfile"
COMPOSE = ROOT / "docker" / "compose.yaml"
SERVICES = {"api", "worker-1", "worker-2", "postgres"}


def compose_cli() -> list[str]:
    if (
        shutil.which("docker")
        and subprocess.run(["docker", "compose", "version"], capture_output=True).returncode == 0
    ):
        return ["docker", "compose"]
    if shutil.which("docker-compose"):
        return ["docker-compose"]
    raise AssertionError(
        "no compose CLI: install one (apt-get install --no-install-recommends docker-compose, "
        "or the docker compose plugin); .ci/run installs it when missing"
    )


def compose(*args: str) -> str:
    result = subprocess.run(
        [*compose_cli(), "-f", str(COMPOSE), *args], capture_output=True, text=True, timeout=60, cwd=ROOT
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


def instruction(name: str) -> list[str]:
    """The exec-form (JSON) argument of the last Dockerfile instruction ``name``."""
    text = DOCKERFILE.read_text().replace("\\\n", " ")
    found = re.findall(rf"^{name}\s+(?:.*?\bCMD\s+)?(\[.*\])\s*$", text, flags=re.MULTILINE)
    assert found, f"no exec-form {name} in {DOCKERFILE}"
    value = json.loads(found[-1])
    assert isinstance(value, list) and all(isinstance(v, str) for v in value)
    return value


def compose_lists(key: str) -> list[list[str]]:
    """Every ``key: [...]`` flow list in compose.yaml (each must be one: checked)."""
    lines = [line for line in COMPOSE.read_text().splitlines() if re.match(rf"^\s*{key}:", line)]
    values = [json.loads(line.split(":", 1)[1]) for line in lines]
    assert all(isinstance(v, list) for v in values), f"write every compose {key} as a JSON-style list"
    return values


def test_compose_file_validates_with_the_services_wired() -> None:
    normalised = compose("config")
    assert set(compose("config", "--services").split()) == SERVICES
    assert normalised.count("condition: service_healthy") == 3  # api and workers wait for postgres
    assert normalised.count("GFC_DATABASE_URL: postgresql://gfc:gfc@postgres:5432/gfc") == 3
    assert normalised.count("gfc-data:/var/lib/gfc") == 3  # workers write frames, the api serves them


@pytest.mark.slow
def test_image_and_compose_commands_are_real_gfc_commands() -> None:
    entrypoint = instruction("ENTRYPOINT")
    assert entrypoint == ["gfc"]
    commands = {tuple(instruction("CMD"))} | {tuple(c) for c in compose_lists("command")}
    assert ("serve", "--host", "0.0.0.0", "--no-worker") in commands
    assert any(c[0] == "worker" for c in commands)
    for command in sorted(commands):
        # --help after the arguments: unknown commands or options still fail (exit 2).
        result = subprocess.run(
            [sys.executable, "-m", "gfc.cli", *command, "--help"], capture_output=True, text=True, timeout=120
        )
        assert result.returncode == 0, f"gfc {' '.join(command)}: {result.stderr or result.stdout}"
    misspelt = subprocess.run(
        [sys.executable, "-m", "gfc.cli", "serve", "--no-wroker", "--help"], capture_output=True, timeout=120
    )
    assert misspelt.returncode == 2  # the check above can fail


def test_image_runs_as_an_unprivileged_user() -> None:
    users = re.findall(r"^USER\s+(\S+)", DOCKERFILE.read_text(), flags=re.MULTILINE)
    assert users and users[-1] not in {"root", "0"}
    assert DOCKERFILE.read_text().count("FROM ") >= 2  # multi-stage: no compilers in the final image


def test_health_checks_hit_live_and_ready(tmp_path: Path) -> None:
    image_check = instruction("HEALTHCHECK")
    (api_check,) = [t for t in compose_lists("test") if any("/health/" in part for part in t)]
    assert "/health/live" in image_check[-1] and "/health/ready" in api_check[-1]
    with running_server(Settings(data_dir=tmp_path), InMemoryLibrary({})) as url:
        host = url.removeprefix("http://")

        def run(check: list[str]) -> int:
            assert check[0] in {"CMD", "python"}
            argv = check[1:] if check[0] == "CMD" else check
            argv = [sys.executable if a == "python" else a.replace("127.0.0.1:8000", host) for a in argv]
            return subprocess.run(argv, capture_output=True, timeout=30).returncode

        assert run(image_check) == 0  # live
        assert run(api_check) == 1  # an empty skill library is not ready (503)
