"""Spatial factors as differentiable least-squares energies (GTSAM style: residual / noise sigma).

Every factor returns residuals ``r`` in natural units (metres or radians) and a tolerance; its
energy is ``E = weight/2 * sum (r / tolerance)^2``, i.e. ``p(satisfied | nodes) ~ exp(-E)``.
During sampling the planner uses the factor *convolved with the current noise*: for a quadratic
energy with precision ``w``, noising by ``sigma`` gives precision ``w / (1 + w sigma^2)``. That
keeps guidance gentle at high noise and exact at zero noise, and keeps Euler steps stable for
stiff constraints.

Node states are world-frame vectors: objects ``pose9``, robots ``pose9 + gripper``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import torch

from gfc.geometry import (
    pose7_to_matrix,
    pose9_to_transform,
    relative_transform,
    transform_points,
    wrap_angle,
    yaw_of_transform,
)
from gfc.kinds import FINGER_THICKNESS, FINGER_WIDTH, PIVOT_TRAVEL, object_kind

Residual = Callable[[Sequence[torch.Tensor], dict[str, Any]], torch.Tensor]


def _pose_of(node: torch.Tensor) -> torch.Tensor:
    return pose9_to_transform(node[..., :9])  # (B, 4, 4)


def _frame_point(node: torch.Tensor, frame: Sequence[float]) -> torch.Tensor:
    point = torch.tensor(list(frame[:3]), dtype=node.dtype)
    return transform_points(_pose_of(node), point.expand(node.shape[0], 3))  # (B, 3)


def inside(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """The object's footprint corners lie within the container's open region. (B, 12)"""
    obj, container = nodes
    hx, hy, _ = object_kind(params["object_kind"]).half_extents
    corners = torch.tensor([[sx * hx, sy * hy, 0.0] for sx in (-1, 1) for sy in (-1, 1)], dtype=obj.dtype)
    world = transform_points(_pose_of(obj).unsqueeze(1), corners.unsqueeze(0))  # (B, 4, 3)
    container_from_world = torch.linalg.inv(_pose_of(container)).unsqueeze(1)  # (B, 1, 4, 4)
    local = transform_points(container_from_world, world)  # (B, 4, 3)
    ix, iy, iz = params["inner_half_extents"]
    margin = params["margin"]
    out = [
        torch.relu(local[..., 0].abs() - (ix - margin)),
        torch.relu(local[..., 1].abs() - (iy - margin)),
        torch.relu(-local[..., 2] - margin) + torch.relu(local[..., 2] - 2 * iz),
    ]
    return torch.cat(out, dim=-1)


def _identity_like(pose: torch.Tensor) -> torch.Tensor:
    """The target's own frame as a pose9 batch shaped like ``pose`` (B, 9): for actions given
    in that frame."""
    frame = torch.tensor([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], dtype=pose.dtype)
    return frame.expand(pose.shape[0], 9)


def released_clear(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """A place action (pose9 of an upright object in the target's frame, both boxes with their
    origin at the bottom centre) releases the object outside the target's box: ``clearance``
    apart in the table plane, or on its top. The residual is how far the better of the two
    falls short. (B, 1)"""
    (pose,) = nodes
    beside = footprint_separation(
        pose, _identity_like(pose), params["object_half_extents"], params["target_half_extents"]
    )
    above = pose[..., 2:3] - 2.0 * float(params["target_half_extents"][2])  # (B, 1)
    # Beside it: ``clearance`` apart; on top: resting on it is enough.
    return torch.relu(-torch.maximum(beside - float(params["clearance"]), above))


def placed_inside(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """``inside`` for a pose given in the container's own frame (a place action). (B, 12)"""
    (pose,) = nodes
    return inside([pose, _identity_like(pose)], params)


def aligned(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """The object's frame point lies over the target's (xy), at ``height`` above it if given; with
    ``offset`` > 0, at that horizontal distance from it (the residual is then the distance's
    error, one component instead of two). (B, 1-3)"""
    obj, target = nodes
    a = _frame_point(obj, params["object_frame"])
    b = _frame_point(target, params["target_frame"])
    r = a[..., :2] - b[..., :2]
    offset = float(params.get("offset") or 0.0)
    if offset > 0.0:
        # sqrt with a floor: the distance's gradient is undefined right over the target.
        r = torch.sqrt((r**2).sum(dim=-1, keepdim=True) + 1e-12) - offset
    if params.get("height") is not None:
        r = torch.cat([r, (a[..., 2:3] - b[..., 2:3]) - params["height"]], dim=-1)
    return r


def _relative_residual(rel: torch.Tensor, ref: torch.Tensor) -> torch.Tensor:
    """Translation and rotation (first two columns) difference of two (B, 4, 4) transforms."""
    dt = rel[..., :3, 3] - ref[..., :3, 3]
    dr = (rel[..., :3, :2] - ref[..., :3, :2]).flatten(-2)
    return torch.cat([dt, dr], dim=-1)


def fixed_transform(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """``inv(T_object) T_target`` is the same at every state, or equals ``transform``."""
    pairs = [(nodes[i], nodes[i + 1]) for i in range(0, len(nodes), 2)]
    rels = [relative_transform(_pose_of(a), _pose_of(b)) for a, b in pairs]
    if params.get("transform") is not None:
        given = torch.tensor(pose7_to_matrix(params["transform"]), dtype=rels[0].dtype)
        return torch.cat([_relative_residual(r, given.expand_as(r)) for r in rels], dim=-1)
    return torch.cat([_relative_residual(r, rels[0]) for r in rels[1:]], dim=-1)


def relative_pose(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """``inv(T_a) T_b`` equals the pose9 given last (a skill's action, e.g. a grasp in the object
    frame). Inputs: (a, b, pose9)."""
    a, b, pose = nodes
    return _relative_residual(relative_transform(_pose_of(a), _pose_of(b)), pose9_to_transform(pose[..., :9]))


def yaw(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    (obj,) = nodes[:1]
    heading = yaw_of_transform(_pose_of(obj)) - float(params["yaw"])
    return wrap_angle(heading).unsqueeze(-1)


def upright(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """The object's z axis points up: its horizontal components (the sine of the tilt, split
    into x and y) are zero. (B, 2)"""
    (obj,) = nodes
    return _pose_of(obj)[..., :2, 2]


def reach(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """The hand is no farther than ``reach`` from the arm's ``shoulder`` (world point). (B, 1)"""
    (hand,) = nodes
    diff = hand[..., :3] - torch.tensor(params["shoulder"], dtype=hand.dtype)
    distance = (diff * diff).sum(dim=-1, keepdim=True).clamp_min(1e-12).sqrt()
    return torch.relu(distance - params["reach"])


def placed_reach(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """``reach`` for the point where a place action (a pose9 in the target's frame) puts the
    object; inputs (target node, action). (B, 1)"""
    target, action = nodes
    point = transform_points(_pose_of(target), action[..., :3])  # (B, 3)
    return reach([point], params)


def palm_clear(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """The hand holding a pour's source is not between it and the target: its approach axis
    (horizontal part) does not point against the pouring direction, the source's rim centre to
    the target's (``source_frame``, ``target_frame``). Inputs: (source node, target node, the
    source's grasp action, a pose9 in its frame). The residual is how far the approach's
    horizontal component along the pouring direction is below 0 (an approach from above has
    none: 0). (B, 1)"""
    source, target, grasp = nodes
    hand = _pose_of(source) @ pose9_to_transform(grasp[..., :9])  # (B, 4, 4)
    approach = hand[..., :2, 2]  # (B, 2): the hand's z axis, into the object
    towards = (_frame_point(target, params["target_frame"]) - _frame_point(source, params["source_frame"]))[
        ..., :2
    ]  # (B, 2)
    direction = towards / towards.norm(dim=-1, keepdim=True).clamp_min(1e-6)
    along = (approach * direction).sum(dim=-1, keepdim=True)  # (B, 1)
    return torch.relu(-along)


def grasp_centred(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """A grasp of a block (pose9 in its frame; the hand's y, the second column, is the fingers'
    closing axis) holds it near the middle of the pads: the grasp point's offset along the pads
    (across the closing axis, in the table plane) is at most ``band``; the residual is the
    excess. (B, 1)"""
    (grasp,) = nodes
    closing = grasp[..., 6:8]
    closing = closing / closing.norm(dim=-1, keepdim=True).clamp_min(1e-9)  # (B, 2)
    across = torch.stack([-closing[..., 1], closing[..., 0]], dim=-1)  # (B, 2)
    lateral = (grasp[..., 0:2] * across).sum(-1, keepdim=True)  # (B, 1)
    return torch.relu(lateral.abs() - float(params["band"]))


def grasps_apart(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """Two grasp actions on one object (pose9 in its frame) at least ``distance`` apart: room
    for both hands at a hand-over. (B, 1)"""
    return far(nodes, params)


def stroke(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """A push (``sign`` +1) or pull (-1) with a hook moves its box-shaped target the way the
    hook's geometry says (gfc/sim/skills/tools.py ``stroke_contact``, the screen's model; within
    a few mm of the simulator on the tasks' strokes). Inputs: (target before, target after,
    action ``(x, y, r, theta)`` in the target's approach frame from the robot's ``base``).

    Residuals (B, 4), metres: the target's xy after the stroke minus where the hook leaves it
    (slid along the stroke by r less the gap the hook closes first); how far the target's centre
    is outside the hook's face (``lateral``, the y span that catches it); and how far the tool
    would come down closer to the target than ``clearance`` (0: inside it); with
    ``max_length``, a fifth: how far the stroke is longer than that (B, 5); with ``max_turn``
    (rad), one more: how far the target's face is turned from the tool's beyond that, times the
    target's half side. With ``shaft_edge`` (a pull), the face's lower end rises to where the
    target's near side clears the shaft; ``margin_gain`` scales the face, clearance and turn
    residuals."""
    before, after, action = nodes
    pose = _pose_of(before)  # (B, 4, 4)
    centre = pose[..., :2, 3]  # (B, 2)
    base = torch.tensor(params["base"][:2], dtype=before.dtype)
    rel = centre - base
    approach_yaw = torch.atan2(rel[..., 1], rel[..., 0])  # (B,)
    x, y, r, theta = action[..., 0], action[..., 1], action[..., 2], action[..., 3]
    tool_yaw = approach_yaw + theta
    sign = float(params["sign"])
    # The target's centre in the tool's frame: the tip frame less the action's tip offset.
    along = torch.cos(theta) * x + torch.sin(theta) * y
    across = float(params["tip"][1]) - (-torch.sin(theta) * x + torch.cos(theta) * y)
    turn = yaw_of_transform(pose) - tool_yaw
    ex, ey = params["half_extents"][:2]
    half_x = ex * torch.cos(turn).abs() + ey * torch.sin(turn).abs()
    gap = -sign * along - float(params["bar_half_x"]) - half_x  # (B,)
    travel = torch.relu(r - torch.relu(gap))
    direction = sign * torch.stack([torch.cos(tool_yaw), torch.sin(tool_yaw)], dim=-1)  # (B, 2)
    across_direction = torch.stack([-direction[..., 1], direction[..., 0]], dim=-1)  # (B, 2)
    # The block turns flat about the corner the face met (gfc.kinds.pivot_shift, as the screen's
    # contact model), fading in over the first PIVOT_TRAVEL of the carry.
    pivot_along, pivot_across = _pivot_shift(turn, ex, ey, half_x)
    fade = torch.clamp(travel / PIVOT_TRAVEL, max=1.0)
    slid = (
        centre
        + (travel + fade * pivot_along).unsqueeze(-1) * direction
        + (fade * pivot_across).unsqueeze(-1) * across_direction
    )
    low, high = params["lateral"]
    if params.get("shaft_edge") is not None:
        # A pull: the block's near side must clear the shaft's edge, or the lowered shaft lands
        # on it (the screen's "the shaft would land on the target").
        half_y = ex * torch.sin(turn).abs() + ey * torch.cos(turn).abs()
        low = torch.clamp(float(params["shaft_edge"]) + half_y, min=low)
    outside = torch.relu(low - across) + torch.relu(across - high)
    short = torch.relu(float(params.get("clearance", 0.0)) - gap)
    # The hook's margins are hard edges (the screen refuses a stroke past them): their residuals
    # count ``margin_gain`` times the sliding error's.
    gain = float(params.get("margin_gain", 1.0))
    out = [after[..., :2] - slid, gain * outside.unsqueeze(-1), gain * short.unsqueeze(-1)]
    if params.get("max_length") is not None:
        out.append(torch.relu(r - float(params["max_length"])).unsqueeze(-1))
    if params.get("max_turn") is not None:
        # A block met askew (its yaw from the tool's, a quarter turn being the same box) slips
        # on its corner: the excess angle, as the arc the block's half side sweeps, a margin.
        folded = torch.atan2(torch.sin(4.0 * turn), torch.cos(4.0 * turn)) / 4.0
        excess = torch.relu(folded.abs() - float(params["max_turn"])) * ex
        out.append(gain * excess.unsqueeze(-1))
    return torch.cat(out, dim=-1)


def _pivot_shift(
    turn: torch.Tensor, ex: float, ey: float, extent: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """``gfc.kinds.pivot_shift`` batched: (along, across) the stroke, m, each (B,); ``extent``
    the box's half extent along the stroke at ``turn``."""
    c, s = torch.cos(turn), torch.sin(turn)
    sign_c = torch.where(c >= 0, torch.ones_like(c), -torch.ones_like(c))  # sign(c), +1 at 0
    lateral = -sign_c * ex * s + torch.sign(s) * ey * c
    flat = turn - torch.atan2(torch.sin(4.0 * turn), torch.cos(4.0 * turn)) / 4.0
    along_flat = ex * torch.cos(flat).abs() + ey * torch.sin(flat).abs()
    across_flat = ex * torch.sin(flat).abs() + ey * torch.cos(flat).abs()
    return along_flat - extent, lateral - torch.sign(lateral) * across_flat


def _footprint_axes(pose: torch.Tensor) -> torch.Tensor:
    """The object's x and y axes projected on the table, unit length. (B, 2, 2): [axis, xy]"""
    axes = pose[..., :2, :2].transpose(-1, -2)  # rows: the x and y axes' world xy
    norm: torch.Tensor = axes.norm(dim=-1, keepdim=True).clamp_min(1e-9)
    return axes / norm


def footprint_separation(
    a: torch.Tensor, b: torch.Tensor, half_a: Sequence[float], half_b: Sequence[float]
) -> torch.Tensor:
    """How far apart two box footprints are (pose9 nodes, half extents; turned as the poses
    are): the separating-axis test on the four edge normals, the best axis's gap, negative when
    they overlap. (B, 1)"""
    pose_a, pose_b = _pose_of(a), _pose_of(b)
    axes_a, axes_b = _footprint_axes(pose_a), _footprint_axes(pose_b)  # (B, 2, 2) each
    extent_a = torch.tensor(list(half_a[:2]), dtype=a.dtype)
    extent_b = torch.tensor(list(half_b[:2]), dtype=a.dtype)
    normals = torch.cat([axes_a, axes_b], dim=-2)  # (B, 4, 2)
    centre = (pose_b[..., :2, 3] - pose_a[..., :2, 3]).unsqueeze(-2)  # (B, 1, 2)

    def radius(axes: torch.Tensor, half: torch.Tensor) -> torch.Tensor:
        # extent of a footprint along each normal: sum_k half_k |axis_k . n|  -> (B, 4)
        return (torch.einsum("bnd,bkd->bnk", normals, axes).abs() * half).sum(-1)

    separation = (normals * centre).sum(-1).abs() - radius(axes_a, extent_a) - radius(axes_b, extent_b)
    return separation.max(dim=-1, keepdim=True).values


def apart(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """Two box footprints are ``clearance`` apart: the residual is how far their separation
    (``footprint_separation``) falls short of it (0 once clear). (B, 1)"""
    a, b = nodes
    gap = footprint_separation(a, b, params["object_half_extents"], params["target_half_extents"])
    return torch.relu(float(params["clearance"]) - gap)


def _fingers(
    placed: torch.Tensor, box_from_grasp: torch.Tensor, params: dict[str, Any]
) -> list[torch.Tensor]:
    """The footprints of the two fingers of a hand at ``box_from_grasp`` (B, 4, 4) closed on a box
    placed at ``placed`` (pose9), as pose9s (B, 9) with half sizes ``finger_thickness / 2`` along
    x (the closing axis) and ``finger_width / 2`` along y.

    The fingers close along the hand's y axis until both meet the box, which centres it between
    them; each finger's footprint is ``finger_thickness`` beyond the box's face along that axis
    (at the height of a neighbour of the same size: the Panda finger's collision hull, measured on
    the screen's mirror) and ``finger_width`` across it, centred on the grasp point."""
    pose = _pose_of(placed)
    hx, hy = (float(v) for v in params["object_half_extents"][:2])
    closing = box_from_grasp[..., :2, 1]
    closing = closing / closing.norm(dim=-1, keepdim=True).clamp_min(1e-9)  # (B, 2)
    across = torch.stack([-closing[..., 1], closing[..., 0]], dim=-1)  # (B, 2)
    axes = _footprint_axes(pose)  # (B, 2, 2): the box's x and y axes on the table
    extent = hx * (axes[..., 0, :] * closing).sum(-1).abs() + hy * (axes[..., 1, :] * closing).sum(-1).abs()
    centre = pose[..., :2, 3]
    lateral = ((box_from_grasp[..., :2, 3] - centre) * across).sum(-1, keepdim=True)  # (B, 1)
    reach = (extent + float(params["finger_thickness"]) / 2).unsqueeze(-1)  # (B, 1)
    zeros = closing.new_zeros((*closing.shape[:-1], 1))
    rotation = torch.cat([closing, zeros, across, zeros], dim=-1)  # (B, 6): x closing, y across
    return [
        torch.cat([centre + side * reach * closing + lateral * across, zeros, rotation], dim=-1)
        for side in (1.0, -1.0)
    ]


def _finger_gap(
    fingers: list[torch.Tensor], others: Sequence[torch.Tensor], params: dict[str, Any]
) -> torch.Tensor:
    """How far the fingers keep from the nearest of ``others`` (pose9 footprints, half extents
    ``params["neighbour_half_extents"]``, one each) and, given ``inner_half_extents``, from the
    walls of the opening the poses are in (its frame). (B, 1)

    Every finger-neighbour pair goes through one separation call (the guidance differentiates
    this at every denoising step: pair by pair, it made packing plans 2.5 times slower)."""
    half = (float(params["finger_thickness"]) / 2, float(params["finger_width"]) / 2)
    finger = torch.stack(fingers, dim=0)  # (F, B, 9)
    count, batch = finger.shape[0], finger.shape[1]
    gaps: list[torch.Tensor] = []  # each (B, 1)
    halves = [tuple(h[:2]) for h in params["neighbour_half_extents"]]
    for extent in dict.fromkeys(halves):  # neighbours of one size at a time (usually all)
        group = torch.stack(
            [o for o, h in zip(others, halves, strict=True) if h == extent], dim=0
        )  # (K, B, 9)
        pairs = (count, group.shape[0], batch, 9)
        separation = footprint_separation(
            finger.unsqueeze(1).expand(pairs).reshape(-1, 9),
            group.unsqueeze(0).expand(pairs).reshape(-1, 9),
            half,
            extent,
        )  # (F * K * B, 1)
        gaps.append(separation.reshape(-1, batch, 1).min(dim=0).values)
    inner = params.get("inner_half_extents")
    if inner is not None:
        walls = torch.tensor(list(inner[:2]), dtype=finger.dtype)
        pose = _pose_of(finger.reshape(-1, 9))  # (F * B, 4, 4)
        signs = torch.tensor([[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]], dtype=finger.dtype)
        # corners: (4, F * B, 2) = centre + sx * hx * x-axis + sy * hy * y-axis
        corners = (
            pose[..., :2, 3]
            + (signs[:, 0:1] * half[0]).unsqueeze(-1) * pose[..., :2, 0]
            + (signs[:, 1:2] * half[1]).unsqueeze(-1) * pose[..., :2, 1]
        )
        to_wall = (walls - corners.abs()).min(dim=-1).values  # (4, F * B)
        gaps.append(to_wall.reshape(4 * count, batch).min(dim=0).values.unsqueeze(-1))
    return torch.stack(gaps, dim=0).min(dim=0).values


def fingers_clear_params(
    held: Sequence[float],
    neighbours: Sequence[Sequence[float]],
    inner: Sequence[float] | None,
    clearance: float,
) -> dict[str, Any]:
    """``fingers_clear``'s parameters: the placed box's half extents, each neighbour's (in the
    order of the nodes after the grasp), the target's opening (None: no walls), the clearance;
    the fingers' size from gfc.kinds. The compiler's factor and the screen's doubt share them."""
    return {
        "clearance": clearance,
        "finger_thickness": FINGER_THICKNESS,
        "finger_width": FINGER_WIDTH,
        "object_half_extents": list(held),
        "neighbour_half_extents": [list(n) for n in neighbours],
        "inner_half_extents": None if inner is None else list(inner),
    }


def fingers_clear(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """The fingers placing a box keep ``clearance`` from the boxes placed before it on the same
    target and from its walls: inputs (this box's place action, its grasp action, then each
    neighbour's place action), poses in the target's frame and the grasp in the box's frame.
    The executor may turn the hand a quarter about the box (a block is the same block turned;
    ``hands_clear_first``), so the better of the grasp and its quarter turn counts, the same
    turn for every neighbour. Residual: how far that gap falls short of ``clearance`` (0 once
    clear). (B, 1)

    Without it the planner kept blocks 9 mm apart while the fingers, 2.5 cm beyond the faces,
    came down on the neighbour: such placements slid 3-4 times as often as clear ones
    (Constrained Packing T1 and T3, scripts/packing_fingers.py)."""
    placed, grasp, *others = nodes
    box_from_placed = _pose_of(placed)
    grasp_pose = _pose_of(grasp)
    quarter = torch.tensor(
        [[0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
        dtype=grasp.dtype,
    )
    gaps = [
        _finger_gap(_fingers(placed, box_from_placed @ turn @ grasp_pose, params), others, params)
        for turn in (torch.eye(4, dtype=grasp.dtype), quarter)
    ]
    return torch.relu(float(params["clearance"]) - torch.maximum(*gaps))


def _distance(nodes: Sequence[torch.Tensor]) -> torch.Tensor:
    a, b = nodes
    diff = a[..., :3] - b[..., :3]
    return (diff * diff).sum(dim=-1, keepdim=True).clamp_min(1e-12).sqrt()


def near(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    return torch.relu(_distance(nodes) - params["distance"])


def far(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    return torch.relu(params["distance"] - _distance(nodes))


def offset(nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """Linear-Gaussian factor on raw node vectors: ``a - b == offset`` (internal; exact in closed
    form, used to check the composition against analytic answers)."""
    a, b = nodes
    return a - b - torch.tensor(params["offset"], dtype=a.dtype)


RESIDUALS: dict[str, Residual] = {
    "offset": offset,
    "inside": inside,
    "aligned": aligned,
    "fixed_transform": fixed_transform,
    "relative_pose": relative_pose,
    "yaw": yaw,
    "upright": upright,
    "reach": reach,
    "grasps_apart": grasps_apart,
    "grasp_centred": grasp_centred,
    "palm_clear": palm_clear,
    "stroke": stroke,
    "apart": apart,
    "fingers_clear": fingers_clear,
    "placed_inside": placed_inside,
    "placed_reach": placed_reach,
    "released_clear": released_clear,
    "near": near,
    "far": far,
}


def scaled_residual(kind: str, nodes: Sequence[torch.Tensor], params: dict[str, Any]) -> torch.Tensor:
    """Residuals divided by the factor's tolerance: dimensionless, 1 = at tolerance. (B, R)"""
    tolerance = float(params.get("tolerance", 0.01))
    return RESIDUALS[kind](nodes, params) / tolerance
