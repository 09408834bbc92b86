"""Zenoh key expressions (DESIGN §3, docs/network.md).

Two kinds of keys, in two name spaces no drone id can cross:

* per drone: ``llmland/<drone_id>/<service>/<topic>``, e.g. ``llmland/d0/sim/state``;
* shared services (the ground station): ``llmland/@ground/...``, e.g. the queryables
  ``llmland/@ground/reasoner/spec`` and ``llmland/@ground/vle/caption`` and the liveliness tokens
  ``llmland/@ground/alive/<service>``.

``@ground`` is a Zenoh *verbatim chunk* (a chunk starting with ``@``): the wildcards ``*`` and
``**`` never match it, so ``llmland/*/vle/scene`` sees drones only and a wildcard query such as
``llmland/**`` never reaches a shared queryable (never starts an LLM inference); only a selector that
names ``@ground`` does. Drone ids are validated (:func:`validate_drone_id`): no ``@``, ``/``,
wildcard or Zenoh-reserved characters, so no drone can take the shared space.
Source: Zenoh key-expression RFC, "Verbatim chunks"
(https://github.com/eclipse-zenoh/roadmap/blob/main/rfcs/ALL/Key%20Expressions.md).
"""

from __future__ import annotations

import re
from enum import StrEnum

PREFIX = "llmland"
DEFAULT_DRONE_ID = "d0"
#: the verbatim chunk of the shared (ground-station) services
GROUND = "@ground"
GROUND_PREFIX = f"{PREFIX}/{GROUND}"
#: a drone id: a letter or digit, then letters, digits, ``_``, ``.``, ``-`` (at most 64 characters)
DRONE_ID_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"
_DRONE_ID_RE = re.compile(DRONE_ID_PATTERN)

#: Queryables shared by every drone (verbatim ``@ground`` chunk: wildcard queries never reach them).
VLE_CAPTION_QUERY = f"{GROUND_PREFIX}/vle/caption"
REASONER_SPEC_QUERY = f"{GROUND_PREFIX}/reasoner/spec"
#: services that serve every drone: liveliness under ``llmland/@ground/alive/<service>``
SHARED_SERVICES = frozenset({"reasoner"})
#: liveliness selectors: every drone's services / every shared service
ALIVE_ANY_DRONE = f"{PREFIX}/*/alive/*"
ALIVE_GROUND = f"{GROUND_PREFIX}/alive/*"


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


#: topics whose payload is a binary camera frame (``application/octet-stream``); every other is JSON
BINARY_TOPICS = frozenset({Topic.CAMERA, Topic.CAMERA_DOWN})


def validate_drone_id(drone_id: str) -> str:
    """``drone_id`` if it is a valid drone id, else ``ValueError`` saying why."""
    if not isinstance(drone_id, str) or not _DRONE_ID_RE.match(drone_id):
        raise ValueError(
            f"invalid drone id {drone_id!r}: use 1-64 letters, digits, '_', '.', '-' starting with a letter or "
            "digit (no '@', '/', '*', '$', '?', '#': those are Zenoh key syntax or the shared '@ground' space)"
        )
    return drone_id


def key(drone_id: str, topic: Topic | str) -> str:
    """Key of ``topic`` for one drone, e.g. ``key("d0", Topic.STATE)``."""
    return f"{PREFIX}/{validate_drone_id(drone_id)}/{Topic(topic).value}"


def any_drone(topic: Topic | str) -> str:
    """Wildcard key matching ``topic`` for every drone (``llmland/*/<topic>``; never ``@ground``)."""
    return f"{PREFIX}/*/{Topic(topic).value}"


def is_shared(key_expr: str) -> bool:
    """Whether a key is in the shared (ground-station) space ``llmland/@ground/...``."""
    return str(key_expr) == GROUND_PREFIX or str(key_expr).startswith(GROUND_PREFIX + "/")


def drone_of(key_expr: str) -> str:
    """The drone id inside a concrete per-drone key; ``ValueError`` for shared or foreign keys."""
    parts = str(key_expr).split("/")
    if len(parts) < 3 or parts[0] != PREFIX:
        raise ValueError(f"not a per-drone llmland key: {key_expr!r}")
    if parts[1].startswith("@"):
        raise ValueError(f"{key_expr!r} is a shared-service key, not a drone's")
    return validate_drone_id(parts[1])


def alive(drone_id: str, service: str) -> str:
    """Liveliness token key of a drone's service (``llmland/<d>/alive/<service>``)."""
    return f"{PREFIX}/{validate_drone_id(drone_id)}/alive/{_service(service)}"


def ground_alive(service: str) -> str:
    """Liveliness token key of a shared service (``llmland/@ground/alive/<service>``)."""
    return f"{GROUND_PREFIX}/alive/{_service(service)}"


def alive_selector(service: str, drone_id: str = "*") -> str:
    """Selector for a service's liveliness token: shared services under ``@ground``, others per drone
    (``drone_id="*"``: any drone)."""
    if service in SHARED_SERVICES:
        return ground_alive(service)
    return f"{PREFIX}/*/alive/{_service(service)}" if drone_id == "*" else alive(drone_id, service)


def _service(name: str) -> str:
    if not _DRONE_ID_RE.match(name):
        raise ValueError(f"invalid service name {name!r}")
    return name
