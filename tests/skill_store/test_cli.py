"""``gfc skills ...`` end to end, on a local folder and on memory:// (the runner is in-process)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from skill_store import SkillStore
from skill_store.cli import skills_app
from skill_store.manifest import WEIGHTS_FILE
from tests.skill_store.conftest import random_model

runner = CliRunner()


def gfc_skills(*args: str, env: dict[str, str] | None = None) -> tuple[int, str]:
    result = runner.invoke(skills_app, list(args), env=env)
    return result.exit_code, result.output


@pytest.fixture
def published(store: SkillStore) -> SkillStore:
    store.publish("pick.hammer", random_model(0), {"seed": 0})
    store.publish("pick.hammer", random_model(1), {"seed": 1})
    return store


def test_an_empty_or_missing_store_lists_nothing(tmp_path: Path) -> None:
    code, output = gfc_skills("list", "--store", str(tmp_path / "missing"))
    assert code == 0 and output.startswith("no skills in")
    code, output = gfc_skills("list", "--json", env={"GFC_SKILL_STORE": str(tmp_path / "missing")})
    assert code == 0 and json.loads(output) == {}


def test_the_packaged_library_lists_without_crashing(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("GFC_SKILL_STORE", raising=False)
    code, _ = gfc_skills("list")
    assert code == 0


def test_list_and_show(published: SkillStore) -> None:
    code, output = gfc_skills("list", "--json", "--store", published.location)
    assert code == 0 and json.loads(output) == {"pick.hammer": {"versions": [1, 2], "aliases": {}}}
    code, output = gfc_skills("list", "pick.hammer", "--json", env={"GFC_SKILL_STORE": published.location})
    assert code == 0 and [v["version"] for v in json.loads(output)["versions"]] == [1, 2]
    code, output = gfc_skills("show", "pick.hammer@1", "--store", published.location)
    assert code == 0 and json.loads(output)["training"]["seed"] == 0


def test_alias_moves_show_in_the_log(published: SkillStore) -> None:
    code, output = gfc_skills(
        "alias", "pick.hammer", "production", "1", "--reason", "canary passed", "--store", published.location
    )
    assert code == 0, output
    code, output = gfc_skills("alias", "pick.hammer", "latest", "production", "--store", published.location)
    assert code == 0 and published.aliases("pick.hammer") == {"production": 1, "latest": 1}
    code, output = gfc_skills("alias", "pick.hammer", "--store", published.location)
    assert code == 0
    assert "production: - -> 1 (canary passed)" in output and "latest: - -> 1" in output


def test_pull_then_push_publishes_a_new_version(published: SkillStore, tmp_path: Path) -> None:
    folder = tmp_path / "checkpoint"
    code, output = gfc_skills("pull", "pick.hammer@1", str(folder), "--store", published.location)
    assert code == 0, output
    code, output = gfc_skills("pull", "pick.hammer@1", str(folder), "--store", published.location)
    assert code == 1 and "--force" in output
    code, output = gfc_skills(
        "push", str(folder), "--name", "pick.wrench", "--alias", "production", "--store", published.location
    )
    assert code == 0, output
    assert published.aliases("pick.wrench") == {"production": 1}
    assert (
        published.manifest("pick.wrench").weights.sha256 == published.manifest("pick.hammer@1").weights.sha256
    )


def test_push_refuses_a_corrupt_checkpoint(published: SkillStore, tmp_path: Path) -> None:
    folder = tmp_path / "checkpoint"
    gfc_skills("pull", "pick.hammer@1", str(folder), "--store", published.location)
    data = bytearray((folder / WEIGHTS_FILE).read_bytes())
    data[-1] ^= 0x80
    (folder / WEIGHTS_FILE).write_bytes(bytes(data))
    code, output = gfc_skills("push", str(folder), "--store", published.location)
    assert code == 1 and "sha256" in output
    assert published.versions("pick.hammer") == (1, 2)


def test_verify_exits_non_zero_when_a_version_fails(published: SkillStore) -> None:
    code, output = gfc_skills("verify", "--store", published.location)
    assert code == 0 and "2 checked, 0 failed" in output
    path = published.backend.path("pick.hammer", "2", WEIGHTS_FILE)
    data = bytearray(published.backend.fs.cat_file(path))
    data[100] ^= 0xFF
    published.backend.fs.pipe_file(path, bytes(data))
    code, output = gfc_skills("verify", "pick.hammer", "--store", published.location)
    assert code == 1 and "FAIL" in output and "2 checked, 1 failed" in output


def test_bad_names_fail_with_a_message_not_a_traceback(published: SkillStore) -> None:
    code, output = gfc_skills("show", "../etc@1", "--store", published.location)
    assert code == 1 and "invalid skill name" in output


def test_prune_keeps_the_newest_and_aliased_versions_and_never_reuses_numbers(published: SkillStore) -> None:
    published.publish("pick.hammer", random_model(2), {"seed": 2})  # versions 1, 2, 3
    published.set_alias("pick.hammer@1", "production")
    code, output = gfc_skills("prune", "--dry-run", "--store", published.location)
    assert code == 0 and "pick.hammer: would remove @2" in output
    assert published.versions("pick.hammer") == (1, 2, 3)  # a dry run removes nothing
    code, output = gfc_skills("prune", "pick.hammer", "--reason", "superseded", "--store", published.location)
    assert code == 0 and "removed @2" in output, output
    assert published.versions("pick.hammer") == (1, 3)
    assert published.load("pick.hammer@1") is not None  # the aliased one is whole
    pruned = [e for e in published.audit_log("pick.hammer") if e.event == "pruned"]
    assert [(e.version, e.reason) for e in pruned] == [(2, "superseded")]
    assert published.publish("pick.hammer", random_model(3), {"seed": 3}) == 4  # 2 stays taken
    with pytest.raises(ValueError, match="at least 1"):
        published.prune("pick.hammer", keep=0)


@pytest.mark.parametrize("command", ["list", "show", "push", "pull", "verify", "alias", "prune"])
def test_help_teaches_with_examples(command: str) -> None:
    code, output = gfc_skills(command, "--help")
    assert code == 0 and "Examples" in output and f"gfc skills {command}" in output
