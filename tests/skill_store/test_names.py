"""Names, versions and references: property tests that no accepted name can leave the store."""

from __future__ import annotations

import posixpath

import pytest
from hypothesis import given
from hypothesis import strategies as st

from skill_store import InvalidNameError, SkillRef, parse_ref
from skill_store.names import (
    MAX_NAME_LENGTH,
    MAX_VERSION,
    parse_version,
    validate_alias,
    validate_name,
)

segment = st.from_regex(r"[a-z][a-z0-9_-]{0,12}", fullmatch=True)
valid_names = st.lists(segment, min_size=1, max_size=4).map(".".join)
valid_aliases = st.from_regex(r"[a-z][a-z0-9_-]{0,20}", fullmatch=True)
versions = st.integers(min_value=1, max_value=MAX_VERSION)


def stays_inside(name: str) -> bool:
    """Joined to a root, the name is one entry directly under it."""
    joined = posixpath.normpath(posixpath.join("/root", name))
    return posixpath.dirname(joined) == "/root" and posixpath.basename(joined) == name


@given(valid_names)
def test_valid_names_are_accepted_and_stay_inside_the_root(name: str) -> None:
    assert validate_name(name) == name
    assert stays_inside(name)


@given(st.text(max_size=120))
def test_any_accepted_text_is_a_safe_path_segment(text: str) -> None:
    try:
        validate_name(text)
    except InvalidNameError:
        return
    assert stays_inside(text)
    assert text == text.lower() and "\\" not in text and "\x00" not in text
    assert not text.startswith(".") and ".." not in text and len(text) <= MAX_NAME_LENGTH


@given(st.text(max_size=20), st.sampled_from(["../", "/", "\\", "..", "\x00", " "]), st.text(max_size=20))
def test_traversal_and_separators_are_refused_anywhere(prefix: str, bad: str, suffix: str) -> None:
    with pytest.raises(InvalidNameError):
        validate_name(prefix + bad + suffix)


@pytest.mark.parametrize(
    "name",
    [
        "../pick",
        "pick/../../etc",
        "/etc/passwd",
        "C:\\skills",
        ".hidden",
        "Pick.Hammer",
        "pick.",
        "",
        "a" * 101,
    ],
)
def test_known_bad_names_are_refused_with_a_hint(name: str) -> None:
    with pytest.raises(InvalidNameError, match=r"skill name"):
        validate_name(name)


@given(versions)
def test_versions_round_trip(version: int) -> None:
    assert parse_version(str(version)) == version


@given(st.integers(max_value=0) | st.integers(min_value=MAX_VERSION + 1))
def test_out_of_range_versions_are_refused(version: int) -> None:
    with pytest.raises(InvalidNameError):
        parse_version(str(version))


@pytest.mark.parametrize("text", ["01", "1.0", "+1", " 1", "1e3", "١"])
def test_versions_have_one_spelling(text: str) -> None:
    with pytest.raises(InvalidNameError):
        parse_version(text)


@given(valid_aliases)
def test_aliases_never_look_like_versions(alias: str) -> None:
    assert validate_alias(alias) == alias
    assert parse_ref(f"pick.hammer@{alias}") == SkillRef("pick.hammer", alias=alias)


@given(valid_names, st.none() | versions, st.none() | valid_aliases)
def test_references_round_trip(name: str, version: int | None, alias: str | None) -> None:
    if version is not None and alias is not None:
        alias = None
    ref = SkillRef(name, version, alias)
    assert parse_ref(str(ref)) == ref


@pytest.mark.parametrize("ref", ["pick.hammer@", "@3", "pick.hammer@../x", "pick.hammer@3@4", "../x@1"])
def test_malformed_references_are_refused(ref: str) -> None:
    with pytest.raises(InvalidNameError):
        parse_ref(ref)
