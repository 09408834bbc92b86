"""Primitive parts and the one-body compound builder every world body is made of.

Every builder creates **one** pybullet body (so a segmentation pixel maps to exactly one
object) made of primitive parts (:class:`Part`): a ``createVisualShapeArray`` with one colour per
part and, for obstacles, a ``createCollisionShapeArray``. All bodies have mass 0, i.e. they
are static or kinematic (moved with ``resetBasePositionAndOrientation``); none is articulated,
which keeps ``stepSimulation`` cheap.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import pybullet as p
from llmland_schemas.arrays import VecLike

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Rgba = tuple[float, float, float, float]

IDENTITY_QUAT: Quat = (0.0, 0.0, 0.0, 1.0)
#: Most shapes pybullet accepts in one createVisualShapeArray / createCollisionShapeArray.
MAX_SHAPES_PER_ARRAY = 16


def quat_yaw(yaw_rad: float) -> Quat:
    return (0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0))


def quat_axis(axis: Vec3, angle_rad: float) -> Quat:
    s = math.sin(angle_rad / 2.0)
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle_rad / 2.0))


Y_AXIS_CYL: Quat = quat_axis((1.0, 0.0, 0.0), math.pi / 2.0)  # cylinder axis z -> y


@dataclass(frozen=True)
class Part:
    """One primitive of a compound body, in the body's base frame (m).

    ``geom`` is a ``pybullet.GEOM_*`` constant: boxes use ``half_extents``, spheres ``radius``,
    cylinders and capsules ``radius`` and ``length`` (the cylindrical part, along local z).
    """

    geom: int
    pos: Vec3
    rgba: Rgba
    half_extents: Vec3 = (0.0, 0.0, 0.0)
    radius: float = 0.0
    length: float = 0.0
    quat: Quat = IDENTITY_QUAT
    collide: bool = True


def box(pos: Vec3, half: Vec3, rgba: Rgba, quat: Quat = IDENTITY_QUAT, collide: bool = True) -> Part:
    """A box part centred at ``pos`` with half extents ``half`` (m)."""
    return Part(p.GEOM_BOX, pos, rgba, half_extents=half, quat=quat, collide=collide)


def sphere(pos: Vec3, radius: float, rgba: Rgba, collide: bool = True) -> Part:
    """A sphere part centred at ``pos`` (m)."""
    return Part(p.GEOM_SPHERE, pos, rgba, radius=radius, collide=collide)


def cylinder(
    pos: Vec3, radius: float, length: float, rgba: Rgba, quat: Quat = IDENTITY_QUAT, collide: bool = True
) -> Part:
    """A cylinder part (axis = local z rotated by ``quat``) centred at ``pos`` (m)."""
    return Part(p.GEOM_CYLINDER, pos, rgba, radius=radius, length=length, quat=quat, collide=collide)


def capsule(pos: Vec3, radius: float, length: float, rgba: Rgba, collide: bool = True) -> Part:
    """A vertical capsule part; total height is ``length + 2 * radius`` (m)."""
    return Part(p.GEOM_CAPSULE, pos, rgba, radius=radius, length=length, collide=collide)


def _shape_arrays(ps: Sequence[Part]) -> dict[str, list]:  # type: ignore[type-arg]
    """The geometry keyword arguments of ``createVisualShapeArray`` / ``createCollisionShapeArray``."""
    return {
        "shapeTypes": [q.geom for q in ps],
        "halfExtents": [list(q.half_extents) for q in ps],
        "radii": [q.radius for q in ps],
        "lengths": [q.length for q in ps],
    }


def _visual_array(client: int, ps: Sequence[Part]) -> int:
    vid = p.createVisualShapeArray(
        **_shape_arrays(ps),
        rgbaColors=[list(q.rgba) for q in ps],
        visualFramePositions=[list(q.pos) for q in ps],
        visualFrameOrientations=[list(q.quat) for q in ps],
        physicsClientId=client,
    )
    if vid < 0:
        raise RuntimeError("pybullet failed to create a compound visual shape")
    return int(vid)


def _collision_array(client: int, cparts: Sequence[Part]) -> int:
    """The collision shape of ``cparts`` (-1 for none: a visual-only body)."""
    if len(cparts) > MAX_SHAPES_PER_ARRAY:
        raise ValueError(f"at most {MAX_SHAPES_PER_ARRAY} collision parts per body")
    if not cparts:
        return -1
    col = p.createCollisionShapeArray(
        **_shape_arrays(cparts),
        collisionFramePositions=[list(q.pos) for q in cparts],
        collisionFrameOrientations=[list(q.quat) for q in cparts],
        physicsClientId=client,
    )
    if col < 0:
        raise RuntimeError("pybullet failed to create a compound collision shape")
    return int(col)


def create_compound(
    client: int,
    parts: Sequence[Part],
    position_m: VecLike,
    yaw_rad: float = 0.0,
    collision_parts: Sequence[Part] | None = None,
) -> int:
    """Create one mass-0 body from ``parts`` and return its pybullet body id.

    Args:
        client: pybullet physics client id.
        parts: visual parts (each with its own colour), in the base frame.
        position_m: base position (3,) in the world frame.
        yaw_rad: base rotation about world z.
        collision_parts: collision geometry; defaults to the parts with ``collide=True``.
            An empty selection makes the body visual-only (never an obstacle).
    """
    if not parts:
        raise ValueError("a compound body needs at least one part")
    # pybullet holds at most MAX_SHAPES_PER_ARRAY shapes per array (more overflow a fixed
    # buffer): extra visual parts go to fixed, mass-0 links of the same body.
    n = MAX_SHAPES_PER_ARRAY
    chunks = [_visual_array(client, parts[k : k + n]) for k in range(0, len(parts), n)]
    cparts = [q for q in parts if q.collide] if collision_parts is None else list(collision_parts)
    col = _collision_array(client, cparts)
    links = chunks[1:]
    zero3 = [0.0, 0.0, 0.0]
    body = p.createMultiBody(
        baseMass=0.0,
        baseCollisionShapeIndex=col,
        baseVisualShapeIndex=chunks[0],
        basePosition=[float(v) for v in position_m],
        baseOrientation=list(quat_yaw(yaw_rad)),
        linkMasses=[0.0] * len(links),
        linkCollisionShapeIndices=[-1] * len(links),
        linkVisualShapeIndices=links,
        linkPositions=[zero3] * len(links),
        linkOrientations=[list(IDENTITY_QUAT)] * len(links),
        linkInertialFramePositions=[zero3] * len(links),
        linkInertialFrameOrientations=[list(IDENTITY_QUAT)] * len(links),
        linkParentIndices=[0] * len(links),
        linkJointTypes=[p.JOINT_FIXED] * len(links),
        linkJointAxis=[[0.0, 0.0, 1.0]] * len(links),
        physicsClientId=client,
    )
    return int(body)
