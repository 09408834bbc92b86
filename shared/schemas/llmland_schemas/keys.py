"""Zenoh key expressions (DESIGN §3): ``llmland/<drone_id>/<service>/<topic>``."""

from __future__ import annotations

from enum import StrEnum

PREFIX = "llmland"
DEFAULT_DRONE_ID = "d0"

#: Queryables shared by every drone.
VLE_CAPTION_QUERY = f"{PREFIX}/vle/caption"
REASONER_SPEC_QUERY = f"{PREFIX}/reasoner/spec"


class Topic(StrEnum):
    """Per-drone topics; the value is the key suffix after the drone id."""

    STATE = "sim/state"
    CAMERA = "sim/camera"
    #: the downward (landing) camera: depth for the planner's tracker, never captioned
    CAMERA_DOWN = "sim/camera_down"
    TRUTH = "sim/truth"
    SCENE = "vle/scene"
    SPEC = "reasoner/spec"
    COMMAND = "planner/command"
    PLAN = "planner/plan"
    MISSION = "mission"
    RESULT = "episode/result"


def key(drone_id: str, topic: Topic | str) -> str:
    """Key of ``topic`` for one drone, e.g. ``key("d0", Topic.STATE)``."""
    if not drone_id or "/" in drone_id or "*" in drone_id:
        raise ValueError(f"invalid drone id {drone_id!r}")
    return f"{PREFIX}/{drone_id}/{Topic(topic).value}"


def any_drone(topic: Topic | str) -> str:
    """Wildcard key matching ``topic`` for every drone (``llmland/*/<topic>``)."""
    return f"{PREFIX}/*/{Topic(topic).value}"


def drone_of(key_expr: str) -> str:
    """The drone id inside a concrete per-drone key."""
    parts = str(key_expr).split("/")
    if len(parts) < 3 or parts[0] != PREFIX:
        raise ValueError(f"not a per-drone llmland key: {key_expr!r}")
    return parts[1]


def alive(drone_id: str, service: str) -> str:
    """Liveliness token key a running service declares (``llmland/<d>/alive/<service>``)."""
    return f"{PREFIX}/{drone_id}/alive/{service}"
