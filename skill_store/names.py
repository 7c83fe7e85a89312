"""Names, versions, aliases and references: what the store accepts before touching any path.

Every name becomes a path segment, so validation is the store's first line against path
traversal: a valid name has no ``/``, ``\\``, ``..``, leading dot or drive letter, is lowercase
(so two skills cannot collide on a case-insensitive filesystem) and is bounded in length.

A reference names one version: ``pick.hammer`` (alias ``latest``, falling back to the highest
version), ``pick.hammer@3`` (a version) or ``pick.hammer@production`` (an alias).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from skill_store.errors import InvalidNameError

MAX_NAME_LENGTH = 100
MAX_ALIAS_LENGTH = 64
MAX_VERSION = 999_999_999  # nine digits: enough for any registry, and no int parsing surprises
LATEST = "latest"

# Dot-separated segments, each starting with a letter: ``pick.hammer``, ``move.empty``.
_NAME = re.compile(r"[a-z][a-z0-9_-]*(?:\.[a-z][a-z0-9_-]*)*")
# An alias starts with a letter, so it can never be mistaken for a version number.
_ALIAS = re.compile(r"[a-z][a-z0-9_-]*")
# Versions are positive integers written without leading zeros, so each has one spelling.
_VERSION = re.compile(r"[1-9][0-9]*")


def validate_name(name: str) -> str:
    """Return ``name`` if it is a valid skill name, else raise ``InvalidNameError``."""
    if not isinstance(name, str) or not name:
        raise InvalidNameError("a skill name must be a non-empty string such as 'pick.hammer'")
    if len(name) > MAX_NAME_LENGTH:
        raise InvalidNameError(f"skill name is {len(name)} characters long; the limit is {MAX_NAME_LENGTH}")
    if _NAME.fullmatch(name) is None:
        raise InvalidNameError(
            f"invalid skill name {name!r}: use lowercase dot-separated words that start with a "
            "letter (letters, digits, '_' and '-'), such as 'pick.hammer'; no '/', '..' or spaces"
        )
    return name


def validate_alias(alias: str) -> str:
    """Return ``alias`` if it is a valid alias name, else raise ``InvalidNameError``."""
    if not isinstance(alias, str) or not alias:
        raise InvalidNameError("an alias must be a non-empty string such as 'production'")
    if len(alias) > MAX_ALIAS_LENGTH:
        raise InvalidNameError(f"alias is {len(alias)} characters long; the limit is {MAX_ALIAS_LENGTH}")
    if _ALIAS.fullmatch(alias) is None:
        raise InvalidNameError(
            f"invalid alias {alias!r}: use a lowercase word that starts with a letter (letters, "
            "digits, '_' and '-'), such as 'production'"
        )
    return alias


def parse_version(text: str) -> int:
    """``"3"`` -> 3; refuses ``"03"``, ``"-1"``, ``"0"`` and numbers above ``MAX_VERSION``."""
    if not isinstance(text, str) or len(text) > len(str(MAX_VERSION)) or _VERSION.fullmatch(text) is None:
        raise InvalidNameError(
            f"invalid version {text!r}: versions are positive integers without leading zeros, "
            f"at most {MAX_VERSION}"
        )
    return int(text)


def validate_version(version: int) -> int:
    """Return ``version`` if it is a valid version number, else raise ``InvalidNameError``."""
    if isinstance(version, bool) or not isinstance(version, int) or not 1 <= version <= MAX_VERSION:
        raise InvalidNameError(f"invalid version {version!r}: versions are integers from 1 to {MAX_VERSION}")
    return version


def is_version_text(text: str) -> bool:
    """Whether a directory name spells a version (listings skip everything else)."""
    try:
        parse_version(text)
    except InvalidNameError:
        return False
    return True


@dataclass(frozen=True)
class SkillRef:
    """A parsed reference: a skill name and either a version, an alias or neither."""

    name: str
    version: int | None = None
    alias: str | None = None

    def __post_init__(self) -> None:
        validate_name(self.name)
        if self.version is not None and self.alias is not None:
            raise InvalidNameError("a reference names a version or an alias, not both")
        if self.version is not None:
            validate_version(self.version)
        if self.alias is not None:
            validate_alias(self.alias)

    def __str__(self) -> str:
        if self.version is not None:
            return f"{self.name}@{self.version}"
        if self.alias is not None:
            return f"{self.name}@{self.alias}"
        return self.name


def parse_ref(ref: str) -> SkillRef:
    """Parse ``name``, ``name@version`` or ``name@alias``."""
    if not isinstance(ref, str) or not ref:
        raise InvalidNameError("a skill reference must be a non-empty string such as 'pick.hammer@3'")
    if len(ref) > MAX_NAME_LENGTH + 1 + MAX_ALIAS_LENGTH:
        raise InvalidNameError(
            f"skill reference is {len(ref)} characters long; that is too long for any valid one"
        )
    name, sep, selector = ref.partition("@")
    if not sep:
        return SkillRef(name)
    if not selector:
        raise InvalidNameError(f"reference {ref!r} ends with '@': add a version or an alias, e.g. '{name}@1'")
    if selector[0].isdigit():
        return SkillRef(name, version=parse_version(selector))
    return SkillRef(name, alias=selector)
