"""Pydantic v2 models for every message on the LLM-Land bus (DESIGN §3).

Every bus message derives from :class:`Envelope` and carries ``schema_version``,
``drone_id``, ``stamp`` (seconds: sim time in lockstep, wall time in realtime) and
``seq``. Units are SI and written into field names (see ``docs/conventions.md``).
Models reject unknown fields and non-finite numbers, so a malformed payload fails
validation instead of reaching a controller.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Annotated, Literal, get_args

from pydantic import Field, FiniteFloat, NonNegativeInt

from .base import Strict
from .camera import MAX_IMAGE_SIDE_PX, CameraIntrinsics

SCHEMA_VERSION: Literal[1] = 1

#: The longest episode a mission may ask for (sim seconds).
MAX_EPISODE_S = 3600.0
#: The paper's default keep-out buffers (LLM-Land abstract): pedestrians 3 m, vehicles 5 m,
#: with the minimum altitude (m) to overfly them.
PERSON_BUFFER_M = 3.0
PERSON_Z_MIN_M = 3.0
VEHICLE_BUFFER_M = 5.0
VEHICLE_Z_MIN_M = 3.0
#: Animals (the knowledge base's animal class: they move less predictably than people and
#: ignore the drone) and static structures (buildings, sheds, trees: clearance for the airframe).
ANIMAL_BUFFER_M = 4.0
STATIC_BUFFER_M = 1.0
#: The scored hard limit (DESIGN §8): never within this distance (m) of a person's body axis.
#: Not a planning buffer: the semantic buffers above keep paths away; this one is a guarantee.
PERSON_HARD_LIMIT_M = 1.0
#: The most conservative class a planner assumes for an obstacle it has no spec for.
CONSERVATIVE_BUFFER_M = 5.0
CONSERVATIVE_Z_MIN_M = 5.0

#: :class:`ControlCommand` mode of a planner that has no command for a tick (its tick raised): the
#: vehicle flies as when a command is missing (the last one held briefly, then its failsafe), at
#: once rather than after the lockstep wait. Its rates and thrust are not flown.
ABSTAIN_MODE = "abstain"

Vec3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]
Quat = tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat]
NonNegFloat = Annotated[FiniteFloat, Field(ge=0.0)]
DroneId = Annotated[str, Field(pattern=r"^[A-Za-z0-9_\-]{1,64}$")]


def vec3(values: Iterable[float]) -> tuple[float, float, float]:
    """Three floats from any iterable (numpy arrays included)."""
    x, y, z = (float(v) for v in values)
    return (x, y, z)


class Envelope(Strict):
    """Fields every bus message carries."""

    schema_version: Literal[1] = SCHEMA_VERSION
    drone_id: DroneId = "d0"
    stamp: NonNegFloat = 0.0
    seq: NonNegativeInt = 0


# --------------------------------------------------------------------------- vehicle


class VehicleState(Envelope):
    """Vehicle state published by the sim (or a real vehicle bridge) each control tick."""

    position_m: Vec3
    velocity_mps: Vec3  # world frame
    quat_xyzw: Quat
    euler_rpy_rad: Vec3  # ZYX roll, pitch, yaw
    body_rates_rps: Vec3  # body frame p, q, r
    on_ground: bool = False
    collided: bool = False
    episode_id: str = ""
    #: lockstep: ``seq`` of the newest camera frame published before this state; a consumer
    #: that tracks frames (the planner) processes that frame before acting on this state
    camera_seq: NonNegativeInt | None = None
    #: lockstep: the same for the downward camera (``sim/camera_down``)
    down_camera_seq: NonNegativeInt | None = None
    #: lockstep: perception results (specs) of frames stamped at or before this time (s) take
    #: effect from this tick on (DESIGN §4: the sim owns the clock and the latency model).
    #: None: no spec yet in lockstep, or realtime (specs apply at ``stamp + latency``)
    specs_released_upto_s: NonNegFloat | None = None


class ControlCommand(Envelope):
    """Body rates and collective thrust for the low-level rate controller.

    ``state_seq`` echoes the ``seq`` of the VehicleState the command answers; in
    lockstep the sim waits for it.
    """

    body_rates_rps: Vec3
    thrust_n: NonNegFloat
    state_seq: NonNegativeInt
    mode: str = "track"  # track | hold | land | fallback | idle | disarm | abstain (ABSTAIN_MODE)
    source: str = "planner"
    solve_ms: NonNegFloat | None = None  # MPC QP solve time of this tick
    tick_ms: NonNegFloat | None = None  # whole controller compute time of this tick


# --------------------------------------------------------------------------- camera


class CameraFrameHeader(Envelope):
    """Typed header sent in front of the raw image bytes (see :mod:`.frames`).

    ``T_world_camera`` is the 4×4 row-major transform from the optical camera frame
    (x right, y down, z forward) into the world.
    """

    width: Annotated[int, Field(gt=0, le=MAX_IMAGE_SIDE_PX)]
    height: Annotated[int, Field(gt=0, le=MAX_IMAGE_SIDE_PX)]
    rgb_encoding: Literal["rgb8"] = "rgb8"
    depth_encoding: Literal["32FC1"] | None = "32FC1"
    intrinsics: CameraIntrinsics
    T_world_camera: Annotated[list[FiniteFloat], Field(min_length=16, max_length=16)]
    vehicle_position_m: Vec3 | None = None
    episode_id: str = ""
    #: which body-mounted camera: the forward-down one (captioned) or the downward one
    camera: Literal["forward", "down"] = "forward"
    #: False: this frame is for depth tracking only; perception (VLE → reasoner) skips it.
    #: In lockstep the sim sends a frame for perception only when perception is free (§4).
    perceive: bool = True


# --------------------------------------------------------------------------- truth


class TruthObject(Strict):
    obj_id: str
    cls: str
    position_m: Vec3
    velocity_mps: Vec3 = (0.0, 0.0, 0.0)
    size_m: Vec3
    dynamic: bool = False
    is_person: bool = False


class GroundTruth(Envelope):
    """What the world really contains. For scoring and visualisation only."""

    world: str
    target_m: Vec3
    objects: list[TruthObject]
    episode_id: str = ""


# --------------------------------------------------------------------------- perception


class Caption(Strict):
    text: str
    backend: str
    model: str = ""
    latency_ms: NonNegFloat = 0.0


class SceneObject(Strict):
    """One obstacle blob found in a depth image, with its crop caption."""

    obj_id: str
    caption: Caption
    centroid_m: Vec3
    size_m: Vec3
    bbox_px: tuple[int, int, int, int] | None = None  # u0, v0, u1, v1


class SceneDescription(Envelope):
    """Captions for a camera frame; ``stamp`` is the frame's stamp."""

    frame_seq: NonNegativeInt = 0
    caption: Caption
    objects: list[SceneObject] = []
    latency_ms: NonNegFloat = 0.0
    episode_id: str = ""


class Evidence(Strict):
    kb_id: str
    score: FiniteFloat


SpecSource = Literal["rag", "llm", "retrieval", "fallback", "given", "oracle"]


class MentionResult(Strict):
    """One obstacle mention in a caption and what it was grounded in (the reasoner's safety layer).

    ``status`` says whether the caption has the thing there (``present``) or says it is not
    (``negated``: "no people"; ``depicted``: "a statue of a man"); only present mentions carry
    spec fields. ``source``: a KB name, a WordNet hypernym, an unknown word (careful), or the
    answer of the LLM (rag) or of retrieval alone.
    """

    text: str
    status: Literal["present", "negated", "depicted"] = "present"
    source: Literal["kb", "wordnet", "unknown", "llm", "retrieval"] = "kb"
    label: str = "unknown"
    kb_id: str = ""
    is_dynamic: bool | None = None
    z_min: NonNegFloat | None = None
    buffer_m: NonNegFloat | None = None


class SafetySpec(Strict):
    """The paper's two fields plus what a planner and an operator need."""

    is_dynamic: bool
    #: a person (True), not one (False), or unknown (None: e.g. the LLM-only baseline, which
    #: has no knowledge base). The planner's hard limit (DESIGN §6) treats unknown as possible.
    is_human: bool | None = None
    z_min: NonNegFloat
    buffer_m: NonNegFloat
    label: str = "unknown"
    caption: str = ""
    evidence: list[Evidence] = []
    source: SpecSource = "fallback"
    model: str = ""
    latency_ms: NonNegFloat = 0.0
    #: why this spec is a fallback (model error, timeout, worker down ...); empty otherwise
    reason: str = ""
    #: every obstacle mention the reasoner found; the spec is the most careful present one
    mentions: list[MentionResult] = []

    @classmethod
    def conservative(cls, caption: str = "", *, model: str = "", latency_ms: float = 0.0,
                     reason: str = "") -> SafetySpec:
        """The most conservative class: dynamic, the largest buffer and altitude floor."""
        return cls(
            is_dynamic=True,
            is_human=None,
            z_min=CONSERVATIVE_Z_MIN_M,
            buffer_m=CONSERVATIVE_BUFFER_M,
            label="unknown",
            caption=caption,
            source="fallback",
            model=model,
            latency_ms=latency_ms,
            reason=reason,
        )


class ObjectSpec(Strict):
    obj_id: str
    centroid_m: Vec3
    size_m: Vec3
    spec: SafetySpec


class SafetySpecMessage(Envelope):
    """Per-object specs for one scene. ``stamp`` is the source frame's stamp."""

    frame_seq: NonNegativeInt = 0
    scene: SafetySpec
    objects: list[ObjectSpec] = []
    latency_ms: NonNegFloat = 0.0
    episode_id: str = ""


# --------------------------------------------------------------------------- planning


class UnsafeBox(Strict):
    obj_id: str
    lo_m: Vec3
    hi_m: Vec3
    label: str = "unknown"
    is_dynamic: bool = False


class CorridorPolytope(Strict):
    """{x | A x <= b}; rows of A are 3-vectors."""

    A: list[Vec3]
    b: list[FiniteFloat]


class ReachDisc(Strict):
    """Where a possible person may be by the end of the descent (the hard limit's reachable set)."""

    track_id: str
    label: str = ""
    centre_m: Vec3  # last observed position (ground point)
    radius_m: NonNegFloat  # body radius + reach over age + descent


class LandingGate(Strict):
    """The landing gate at one tick (planner ``landing.py``): why the vehicle descends or waits."""

    open: bool
    duration_s: NonNegFloat  # the rest of the descent, touchdown dwell included
    margin_m: float  # the hard limit's worst margin (≥ 0: provably > 1 m from everyone)
    binding: str = ""  # the binding track id; "" = untracked people (coverage); "-" = nobody
    disc_clear: bool = True
    coverage_m: NonNegFloat = 0.0  # downward camera coverage radius
    people: list[ReachDisc] = []


class PlanSnapshot(Envelope):
    """What the planner is doing: phase, reference path, corridors, unsafe regions, the gate.

    Published when a new plan is adopted, when the phase changes, and at most every
    0.5 s otherwise (for displays)."""

    mode: str
    reference_m: list[Vec3] = []
    corridors: list[CorridorPolytope] = []
    regions: list[UnsafeBox] = []
    search_ms: NonNegFloat | None = None
    episode_id: str = ""
    target_m: Vec3 | None = None
    gate: LandingGate | None = None


# --------------------------------------------------------------------------- episodes

WorldName = Literal["open_field", "urban", "forest_edge"]
#: reference: the sim's own position controller; baseline: geometry, one fixed margin;
#: conservative: geometry, every obstacle treated as a person; llm: LLM-MPC (no retrieval);
#: llm-land: RAG (the paper's method)
MethodName = Literal["reference", "baseline", "conservative", "llm", "llm-land"]
#: every world and every method, in the order of their ``Literal`` (the one list of each)
WORLD_NAMES: tuple[WorldName, ...] = get_args(WorldName)
METHOD_NAMES: tuple[MethodName, ...] = get_args(MethodName)
#: the methods whose planner reads semantic specs (and so fly with perception)
SEMANTIC_METHODS: tuple[MethodName, ...] = ("llm", "llm-land")
ClockMode = Literal["lockstep", "realtime"]
#: where semantic specs come from: nowhere, the VLE → reasoner pipeline, or ground truth
PerceptionSource = Literal["none", "pipeline", "oracle"]
#: ``measured`` | ``fixed:<ms>`` | ``normal:<mean_ms>,<sd_ms>`` (DESIGN §4)
LATENCY_MODEL_PATTERN = r"^(measured|fixed:\d+(\.\d+)?|normal:\d+(\.\d+)?,\d+(\.\d+)?)$"
#: a scripted test scenario: ``walk-in:<distance_m>,<speed_mps>``
SCENARIO_PATTERN = r"^walk-in:\d+(\.\d+)?,\d+(\.\d+)?$"


class GivenSpec(Strict):
    """A spec handed to the planner directly for an object class (no perception)."""

    cls: str
    spec: SafetySpec


class MissionGoal(Envelope):
    """Episode control from the CLI to the sim and the planner."""

    command: Literal["start", "stop"] = "start"
    episode_id: str
    world: WorldName = "open_field"
    seed: NonNegativeInt = 1
    method: MethodName = "reference"
    clock: ClockMode = "lockstep"
    timeout_s: Annotated[FiniteFloat, Field(gt=0, le=MAX_EPISODE_S)] = 60.0
    start_m: Vec3 | None = None  # filled by the sim from the world when None
    target_m: Vec3 | None = None
    n_pedestrians: NonNegativeInt | None = None
    given_specs: list[GivenSpec] = []
    #: where specs come from; the sim paces perception requests for ``pipeline``/``oracle``
    perception: PerceptionSource = "none"
    #: lockstep: when a spec takes effect, ``frame stamp + latency`` (DESIGN §4)
    latency_model: Annotated[str, Field(pattern=LATENCY_MODEL_PATTERN)] = "measured"
    #: a scripted test scenario on top of the seeded world, e.g. ``walk-in:5.5,1.5`` (a person
    #: standing 5.5 m from the target walks to it at up to 1.5 m/s once the final descent starts)
    scenario: Annotated[str, Field(pattern=SCENARIO_PATTERN)] | None = None
    #: Where the sim records this episode to Rerun (a path on the sim's host), if at all.
    rrd_path: str | None = None


class EpisodeResult(Envelope):
    """Scored outcome of one episode (DESIGN §8)."""

    episode_id: str
    world: str
    seed: int
    method: str
    clock: str
    success: bool
    outcome: Literal["landed", "off_target", "collision", "close_call", "timeout", "aborted"]
    touchdown_m: Vec3 | None = None
    touchdown_error_m: NonNegFloat | None = None
    time_to_land_s: NonNegFloat | None = None
    min_person_distance_m: dict[str, NonNegFloat] = {}
    close_calls: NonNegativeInt = 0
    collisions: list[str] = []
    sim_time_s: NonNegFloat = 0.0
    wall_time_s: NonNegFloat = 0.0
    control_ticks: NonNegativeInt = 0
    deadline_misses: NonNegativeInt = 0
    commands_missing: NonNegativeInt = 0
    #: mean perception latency as applied (frame stamp → spec in effect, sim time), ms
    spec_latency_ms_mean: NonNegFloat | None = None
    #: mean compute time the producers reported (VLE + reasoner wall time), ms
    spec_compute_ms_mean: NonNegFloat | None = None
    latency_model: str = ""
    perception_requests: NonNegativeInt = 0
    #: requests never answered within the sim's perception timeout
    perception_lost: NonNegativeInt = 0
    #: perception (VLE or reasoner) was down at some time, and for how long (sim s)
    perception_degraded: bool = False
    perception_degraded_s: NonNegFloat = 0.0
    #: a fault run's killed services, each with the sim time (s) it was first seen dead; filled
    #: by whoever killed them (``llmland land --kill``), never by the sim, which cannot tell
    services_killed_at_s: dict[str, NonNegFloat] = {}
    #: object specs that were the reasoner's conservative fallback (model error, worker down)
    fallback_specs: NonNegativeInt = 0
    mpc_solve_ms_p50: NonNegFloat | None = None
    mpc_solve_ms_p95: NonNegFloat | None = None
    rrd_path: str | None = None
