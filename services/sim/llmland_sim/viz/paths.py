"""Entity paths of a landing recording (DESIGN §9) and the time line they are logged on.

One place for the names, so the recorder, the blueprint and the tests agree.
"""

from __future__ import annotations

import rerun as rr

TIMELINE = "sim_time"

WORLD = "world"
DRONE = "world/drone"  # the body: Boxes3D in the body frame, placed by InstancePoses3D (the pose)
TRAJECTORY = "world/drone/trajectory"  # world frame (InstancePoses3D does not propagate to children)
CAMERA_FRUSTUM = "world/camera"
CAMERA_DOWN_FRUSTUM = "world/camera_down"
REFERENCE = "world/plan/reference"
CORRIDORS = "world/plan/corridors"
UNSAFE = "world/unsafe"  # + /<track id>
OBSTACLES = "world/obstacles"  # + /<obj id>
ACTORS = "world/actors"  # + /<obj id>
TARGET = "world/target"
GATE = "world/gate"
GATE_PEOPLE = "world/gate/people"
GATE_COVERAGE = "world/gate/coverage"

CAMERA_RGB = "camera/rgb"
CAMERA_BLOBS = "camera/rgb/blobs"
CAMERA_DEPTH = "camera/depth"
CAMERA_DOWN_RGB = "camera_down/rgb"
CAMERA_DOWN_BLOBS = "camera_down/rgb/blobs"

SCENE_CAPTION = "scene/caption"
LOG = "log"
LOG_PHASE = "log/phase"
LOG_GATE = "log/gate"
LOG_CAPTIONS = "log/captions"
LOG_SPECS = "log/specs"

PLOT_ALTITUDE = "plot/altitude_m"
PLOT_PERSON = "plot/person_distance_m"
PLOT_PERSON_CLOSEST = "plot/person_distance_m/closest"
PLOT_PERSON_LIMIT = "plot/person_distance_m/limit_1m"
PLOT_PERSON_BUFFER = "plot/person_distance_m/buffer"
PLOT_MPC_SOLVE = "plot/mpc_solve_ms"
PLOT_SEARCH = "plot/search_ms"
PLOT_SPEC_LATENCY = "plot/spec_latency_ms"

#: DESIGN §9: every one of these exists in a semantic run (``<id>`` paths as their parent).
DESIGN_PATHS: tuple[str, ...] = (
    DRONE, TRAJECTORY, REFERENCE, CORRIDORS, UNSAFE, OBSTACLES, ACTORS, TARGET,
    CAMERA_RGB, CAMERA_DEPTH, SCENE_CAPTION, PLOT_MPC_SOLVE, PLOT_SPEC_LATENCY,
)


def child(parent: str, name: str) -> str:
    """``parent/name`` with ``name`` escaped as one path part (ids may hold any character)."""
    return f"{parent}/{rr.escape_entity_path_part(name)}"
