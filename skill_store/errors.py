"""What can go wrong in the skill store, as one exception hierarchy.

Every message says what is wrong and what to do about it, because these errors reach people
through the CLI and the service's 4xx/5xx responses unchanged.
"""

from __future__ import annotations


class SkillStoreError(Exception):
    """Base class of every skill store error."""


class InvalidNameError(SkillStoreError, ValueError):
    """A skill name, version, alias or reference that the store refuses (bad characters, path
    traversal, too long)."""


class SkillNotFoundError(SkillStoreError, KeyError):
    """No such skill, version or alias in the store."""

    def __str__(self) -> str:
        # KeyError quotes its argument; a sentence reads better unquoted.
        return str(self.args[0]) if self.args else ""


class IntegrityError(SkillStoreError):
    """A stored version fails its checks: its weights do not hash to the manifest's sha256, or
    its manifest does not describe its weights. The store never loads such a version."""


class ManifestError(IntegrityError):
    """A manifest that cannot be read or does not follow the schema."""


class PublishError(SkillStoreError):
    """Publishing could not complete (no free version number, a model the store cannot hold)."""
