"""People, vehicles and built obstacles: person, car / van, building, shed, crate."""

from __future__ import annotations

import math

import numpy as np
from llmland_schemas.arrays import VecLike

from .colours import BUILDING, CAR, GLASS, HAIR, PANTS, SKIN, TYRE, jitter, pick, shade
from .primitives import Y_AXIS_CYL, Part, Vec3, box, capsule, create_compound, cylinder, quat_axis, sphere

#: Person height used by :func:`create_person` by default (m).
PERSON_HEIGHT_M = 1.7
#: How far roof / windows / door of a building stick out of its walls (m).
BUILDING_OVERHANG_M = 0.06
#: How far a vehicle's lights stick out of its nominal length (m, each end).
VEHICLE_OVERHANG_M = 0.03
#: Default car extents (length, width, height) in metres.
CAR_SIZE_M: Vec3 = (4.3, 1.8, 1.5)
#: Default van extents (length, width, height) in metres.
VAN_SIZE_M: Vec3 = (5.0, 1.95, 2.1)


def create_person(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike = (0.0, 0.0, 0.0),
    yaw_rad: float = 0.0,
    height_m: float = PERSON_HEIGHT_M,
) -> int:
    """Humanoid silhouette (legs, torso, arms, neck, head, hair) facing local +x.

    Extents ≈ 0.3 (x) × 0.62 (y) × ``height_m`` (z); base at the feet. Collision is one capsule
    of radius 0.25 m spanning the full height (kinematic, mass 0).
    """
    s = height_m / PERSON_HEIGHT_M
    skin = pick(rng, SKIN, 0.03)
    shirt = jitter(rng, rng.uniform(0.1, 0.9, 3), 0.0)
    pants = pick(rng, PANTS, 0.04)
    hair = pick(rng, HAIR, 0.03)
    parts = [
        capsule((0.0, 0.1 * s, 0.44 * s), 0.075 * s, 0.72 * s, pants, collide=False),
        capsule((0.0, -0.1 * s, 0.44 * s), 0.075 * s, 0.72 * s, pants, collide=False),
        box((0.0, 0.0, 0.92 * s), (0.11 * s, 0.18 * s, 0.07 * s), pants, collide=False),
        box((0.0, 0.0, 1.18 * s), (0.12 * s, 0.19 * s, 0.25 * s), shirt, collide=False),
        capsule((0.0, 0.255 * s, 1.13 * s), 0.055 * s, 0.46 * s, shirt, collide=False),
        capsule((0.0, -0.255 * s, 1.13 * s), 0.055 * s, 0.46 * s, shirt, collide=False),
        cylinder((0.0, 0.0, 1.47 * s), 0.05 * s, 0.08 * s, skin, collide=False),
        sphere((0.0, 0.0, 1.585 * s), 0.11 * s, skin, collide=False),
        sphere((-0.02 * s, 0.0, 1.61 * s), 0.1 * s, hair, collide=False),
    ]
    coll = [capsule((0.0, 0.0, 0.5 * height_m), 0.25 * s, height_m - 0.5 * s, skin)]
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=coll)


def create_car(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    yaw_rad: float = 0.0,
    kind: str = "car",
) -> int:
    """Car (4.3×1.8×1.5 m) or van (5.0×1.95×2.1 m): body, glass cabin, roof, wheels, lights.

    Local +x is the front (headlights). Collision: body and cabin boxes.
    """
    paint = pick(rng, CAR, 0.04)
    parts: list[Part] = []
    if kind == "car":
        length, width, height = CAR_SIZE_M
        body_top, body_len = 0.95, length
        cabin_len, cabin_x = 2.3, -0.25
    elif kind == "van":
        length, width, height = VAN_SIZE_M
        body_top, body_len = 1.05, length
        cabin_len, cabin_x = 3.9, -0.45
    else:
        raise ValueError(f"unknown vehicle kind {kind!r}")
    clearance, wheel_r = 0.28, 0.33
    hl, hw = body_len / 2.0, width / 2.0
    parts.append(box((0.0, 0.0, 0.5 * (clearance + body_top)), (hl, hw, 0.5 * (body_top - clearance)), paint))
    roof_t = 0.06
    cab_h = height - body_top - roof_t
    parts.append(box((cabin_x, 0.0, body_top + cab_h / 2.0), (cabin_len / 2.0, hw - 0.08, cab_h / 2.0), GLASS))
    parts.append(box((cabin_x, 0.0, height - roof_t / 2.0), (cabin_len / 2.0 + 0.02, hw - 0.03, roof_t / 2.0), paint))
    if kind == "van":  # rear body panels (under the roof) so the van is not a glass box
        parts.append(
            box(
                (cabin_x - 0.6, 0.0, body_top + cab_h / 2.0 - 0.01),
                (cabin_len / 2.0 - 0.6, hw - 0.05, cab_h / 2.0 - 0.01),
                paint,
                collide=False,
            )
        )
    wx = hl - 0.8
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            parts.append(
                cylinder((sx * wx, sy * (hw - 0.12), wheel_r), wheel_r, 0.24, TYRE, quat=Y_AXIS_CYL, collide=False)
            )
    light_z = body_top - 0.2
    for sy in (-1.0, 1.0):
        parts.append(
            box((hl + 0.01, sy * (hw - 0.25), light_z), (0.02, 0.14, 0.06), (1.0, 0.97, 0.8, 1.0), collide=False)
        )
        parts.append(
            box((-hl - 0.01, sy * (hw - 0.25), light_z), (0.02, 0.14, 0.06), (0.8, 0.05, 0.05, 1.0), collide=False)
        )
    coll = [parts[0], parts[1]]
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=coll)


def create_building(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    size_m: Vec3,
    yaw_rad: float = 0.0,
) -> int:
    """Block building ``size_m = (x, y, z)`` with roof slab, window bands and a door on +x.

    Roof, windows and door stick out up to :data:`BUILDING_OVERHANG_M` beyond the walls; the
    roof slab adds 0.2 m of height.
    """
    sx, sy, sz = size_m
    wall = pick(rng, BUILDING, 0.05)
    roof = shade(wall, 0.6)
    parts: list[Part] = [box((0.0, 0.0, sz / 2.0), (sx / 2.0, sy / 2.0, sz / 2.0), wall)]
    parts.append(box((0.0, 0.0, sz + 0.1), (sx / 2.0 + 0.05, sy / 2.0 + 0.05, 0.1), roof))
    floor_h = float(rng.uniform(2.9, 3.4))
    n_floors = max(1, int(sz / floor_h))
    for k in range(n_floors):
        zc = (k + 0.55) * floor_h
        if zc + 0.6 > sz - 0.3:
            break
        if k == 0:
            continue  # ground floor: door only
        parts.append(box((sx / 2.0 + 0.02, 0.0, zc), (0.02, sy / 2.0 - 0.6, 0.6), GLASS, collide=False))
        parts.append(box((-sx / 2.0 - 0.02, 0.0, zc), (0.02, sy / 2.0 - 0.6, 0.6), GLASS, collide=False))
        parts.append(box((0.0, sy / 2.0 + 0.02, zc), (sx / 2.0 - 0.6, 0.02, 0.6), GLASS, collide=False))
        parts.append(box((0.0, -sy / 2.0 - 0.02, zc), (sx / 2.0 - 0.6, 0.02, 0.6), GLASS, collide=False))
    parts.append(box((sx / 2.0 + 0.03, 0.0, 1.1), (0.03, 0.8, 1.1), (0.25, 0.18, 0.12, 1.0), collide=False))
    coll = [parts[0], parts[1]]
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=coll)


def create_shed(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    size_m: Vec3,
    yaw_rad: float = 0.0,
) -> int:
    """Garden shed: walls ``size_m = (x, y, wall height)``, gable roof (ridge along x), door on +x.

    Roof overhang 0.2 m (x) and 0.25 m (y), pitch 25°; see :func:`shed_height`.
    """
    sx, sy, hw = size_m
    wall = jitter(rng, [(0.55, 0.35, 0.2), (0.6, 0.15, 0.12), (0.5, 0.52, 0.5)][int(rng.integers(3))], 0.05)
    roof = jitter(rng, (0.22, 0.2, 0.2), 0.04)
    pitch = math.radians(25.0)
    ov_y = 0.25
    run = sy / 2.0 + ov_y
    plate_w = run / math.cos(pitch)
    ridge_z = hw + (sy / 2.0) * math.tan(pitch)
    parts: list[Part] = [box((0.0, 0.0, hw / 2.0), (sx / 2.0, sy / 2.0, hw / 2.0), wall)]
    # gable end fill (a box up to the ridge, narrower so it stays under the roof plates)
    gable_h = ridge_z - hw
    parts.append(box((0.0, 0.0, hw + gable_h / 2.0 - 0.05), (sx / 2.0, sy / 4.0, gable_h / 2.0), wall))
    for sgn in (-1.0, 1.0):
        yc = sgn * run / 2.0
        zc = ridge_z - (run / 2.0) * math.tan(pitch) + 0.05
        parts.append(
            box(
                (0.0, yc, zc),
                (sx / 2.0 + 0.2, plate_w / 2.0, 0.05),
                roof,
                quat=quat_axis((1.0, 0.0, 0.0), -sgn * pitch),
            )
        )
    parts.append(box((sx / 2.0 + 0.02, 0.0, 0.95), (0.02, 0.45, 0.95), (0.15, 0.1, 0.07, 1.0), collide=False))
    return create_compound(client, parts, position_m, yaw_rad)


def shed_height(size_m: Vec3) -> float:
    """Total height (m) of a :func:`create_shed` shed (ridge top)."""
    return size_m[2] + (size_m[1] / 2.0) * math.tan(math.radians(25.0)) + 0.1


def create_crate(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    size_m: Vec3,
    yaw_rad: float = 0.0,
) -> int:
    """Box / crate ``size_m = (x, y, z)`` standing on the ground, wood or painted."""
    sx, sy, sz = size_m
    colour = jitter(
        rng, [(0.6, 0.45, 0.25), (0.25, 0.4, 0.6), (0.7, 0.65, 0.55), (0.5, 0.2, 0.15)][int(rng.integers(4))]
    )
    parts = [
        box((0.0, 0.0, sz / 2.0), (sx / 2.0, sy / 2.0, sz / 2.0), colour),
        box((0.0, 0.0, sz + 0.01), (sx / 2.0 - 0.05, sy / 2.0 - 0.05, 0.01), shade(colour, 0.75), collide=False),
    ]
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=[parts[0]])
