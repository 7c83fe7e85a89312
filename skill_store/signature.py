"""A stored model's signature, derived from the skill catalogue when its name names a skill.

Model names are ``skill.object_kind`` (``pick.hammer``, ``move.empty``); when the first part is
a skill in ``gfc.skills.signatures`` and the layout matches that skill's tokens, the manifest
records each token's entity (role), phase and frames, so a reader knows what the numbers mean
without the code that trained the model.
"""

from __future__ import annotations

from gfc.diffusion.denoiser import TokenLayout
from gfc.skills.signatures import SKILLS
from skill_store.manifest import Signature, TokenEntry

# Inside a skill model, robot and object nodes are in the acting robot's base frame.
NODE_FRAME = "acting robot's base frame"


def signature_for(name: str, layout: TokenLayout) -> Signature:
    """The signature of model ``name`` with this layout (roles left out when unknown)."""
    spec = SKILLS.get(name.split(".")[0])
    if spec is not None:
        for with_object in (True, False):
            tokens = spec.tokens(with_object)
            dims = tuple(t.dim for t in tokens)
            types = tuple(t.kind for t in tokens)
            if (dims, types) == (layout.dims, layout.types):
                return Signature(
                    skill=spec.name,
                    tokens=[TokenEntry(dim=t.dim, type=t.kind, role=t.role, phase=t.phase) for t in tokens],
                    node_frame=NODE_FRAME,
                    action_frame=spec.action_frame,
                )
    entries = [TokenEntry(dim=d, type=t) for d, t in zip(layout.dims, layout.types, strict=True)]
    return Signature(tokens=entries)
