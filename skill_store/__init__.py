"""Versioned, atomic, integrity-checked skill checkpoints (safetensors + manifest).

    from skill_store import SkillStore, StoreLibrary

    store = SkillStore("s3://bucket/skills")          # or a folder; default: the packaged library
    version = store.publish("pick.hammer", model, {"seed": 0, "command": "gfc train ..."})
    store.set_alias(f"pick.hammer@{version}", "production")
    model = store.load("pick.hammer@production")      # checked: sha256, shapes, statistics
    library = StoreLibrary(store)                      # the planner's SkillLibrary

See docs/skill_store.md for the layout on disk and how each backend publishes atomically.
"""

from skill_store.errors import (
    IntegrityError,
    InvalidNameError,
    ManifestError,
    PublishError,
    SkillNotFoundError,
    SkillStoreError,
)
from skill_store.library import StoreLibrary
from skill_store.manifest import Manifest
from skill_store.names import SkillRef, parse_ref
from skill_store.store import DEFAULT_LIBRARY, ResolvedRef, SkillState, SkillStore, VerifyResult
from skill_store.watcher import StoreChange, StoreWatcher

__all__ = [
    "DEFAULT_LIBRARY",
    "IntegrityError",
    "InvalidNameError",
    "Manifest",
    "ManifestError",
    "PublishError",
    "ResolvedRef",
    "SkillNotFoundError",
    "SkillRef",
    "SkillState",
    "SkillStore",
    "SkillStoreError",
    "StoreChange",
    "StoreLibrary",
    "StoreWatcher",
    "VerifyResult",
    "parse_ref",
]
