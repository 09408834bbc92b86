"""Pybullet body builders for the LLM-Land worlds (people, cars, buildings, vegetation, ...).

- :mod:`.primitives` — parts (box, sphere, cylinder, capsule) and the one-body compound;
- :mod:`.colours` — seeded palettes and colour helpers;
- :mod:`.textures` — seeded textures and textured meshes;
- :mod:`.surfaces` — ground, heightfield terrain, streets, flat markings, the landing pad;
- :mod:`.props` — people, vehicles, buildings, sheds, crates;
- :mod:`.vegetation` — trees, bushes, rocks.

Frames: every body's base frame sits on the ground at the centre of its footprint (``z`` up,
world frame ENU per ``docs/conventions.md``); local ``+x`` is the object's "forward" (a
person's facing direction, a car's front, a building's door side). ``position_m`` is that
base point and ``yaw_rad`` the rotation about world ``z``. Sizes are in metres.
"""

from .primitives import (
    IDENTITY_QUAT,
    MAX_SHAPES_PER_ARRAY,
    Part,
    Quat,
    Rgba,
    Vec3,
    VecLike,
    box,
    capsule,
    create_compound,
    cylinder,
    sphere,
)
from .props import (
    BUILDING_OVERHANG_M,
    CAR_SIZE_M,
    PERSON_HEIGHT_M,
    VAN_SIZE_M,
    VEHICLE_OVERHANG_M,
    create_building,
    create_car,
    create_crate,
    create_person,
    create_shed,
    shed_height,
)
from .surfaces import (
    LAYER_M,
    MARKING_TOP_M,
    PAD_TOP_M,
    SIDEWALK_TOP_M,
    STREET_TOP_M,
    create_flat_rects,
    create_ground,
    create_heightfield,
    create_landing_pad,
    create_street,
)
from .textures import GRASS_TILE_M, create_textured_mesh_body, grass_image, solid_image
from .vegetation import create_bush, create_rock, create_tree, tree_footprint_radius, tree_height, tree_trunk_radius

__all__ = [
    "BUILDING_OVERHANG_M",
    "CAR_SIZE_M",
    "GRASS_TILE_M",
    "IDENTITY_QUAT",
    "LAYER_M",
    "MARKING_TOP_M",
    "MAX_SHAPES_PER_ARRAY",
    "PAD_TOP_M",
    "PERSON_HEIGHT_M",
    "SIDEWALK_TOP_M",
    "STREET_TOP_M",
    "VAN_SIZE_M",
    "VEHICLE_OVERHANG_M",
    "Part",
    "Quat",
    "Rgba",
    "Vec3",
    "VecLike",
    "box",
    "capsule",
    "create_building",
    "create_bush",
    "create_car",
    "create_compound",
    "create_crate",
    "create_flat_rects",
    "create_ground",
    "create_heightfield",
    "create_landing_pad",
    "create_person",
    "create_rock",
    "create_shed",
    "create_street",
    "create_textured_mesh_body",
    "create_tree",
    "cylinder",
    "grass_image",
    "shed_height",
    "solid_image",
    "sphere",
    "tree_footprint_radius",
    "tree_height",
    "tree_trunk_radius",
]
