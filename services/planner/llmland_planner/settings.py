"""Planner settings, read once from ``LLMLAND_PLANNER_*`` environment variables."""

from __future__ import annotations

from pydantic import model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from .coverage import PersonTorso
from .tracking import FORGET_AFTER_S, GATE_M, PREDICT_CAP_S


class PlannerSettings(BaseSettings):
    """Everything the planner service reads (SI units)."""

    model_config = SettingsConfigDict(env_prefix="LLMLAND_PLANNER_", extra="ignore")

    drone_id: str = "d0"
    # MPC
    horizon: int = 20
    mpc_dt_s: float = 0.05
    max_halfspaces: int = 8
    # search and replanning
    search_budget_s: float = 0.08
    #: lockstep clock: the search is bounded by expansions (not wall time) and its plan is
    #: adopted exactly ``search_budget_s`` of sim time after the search started, so a seeded
    #: episode is reproducible whatever the machine's load (≈ 260 µs per expansion here)
    search_max_expansions: int = 400
    replan_period_s: float = 1.0
    sweep_horizon_s: float = 2.0
    # perception and semantics
    baseline_margin_m: float = 1.0
    #: a still thing a side view cut at the top may reach this far (m) past its seen footprint
    #: above what was seen: the forward camera, pitched down, never sees its own altitude, and a
    #: tree's crown spreads over its trunk (crowns here up to 3.0 m from the trunk:
    #: ``llmland_sim`` broadleaf trees, 1.15 x a crown radius of at most 2.6 m)
    unseen_top_reach_m: float = 3.0
    #: a spec applies to tracks whose centroid is within max(this, the object's radius) (m) of its object
    spec_match_m: float = 0.6
    #: a spec of something that may move is trusted this long (s) without a new one
    spec_stale_s: float = 8.0
    #: a static thing's spec is void once its track's height changed by more than this (m)
    spec_height_tolerance_m: float = 0.4
    #: a moving thing of a static class is taken for a misread person when it is this size:
    #: height (m) at least ... and horizontal half-diagonal (m) at most ...
    person_min_height_m: float = 0.8
    person_max_radius_m: float = 0.8
    moving_speed_mps: float = 0.25
    moving_displacement_m: float = 1.0
    #: out of view, constant-velocity prediction is trusted this long (s)
    predict_cap_s: float = PREDICT_CAP_S
    #: a thing that has moved and has not been seen for this long (s) is no longer where it was
    #: seen: it leaves the path keep-out (not the hard limit's people, nor the landing disc check)
    moved_unseen_keepout_s: float = PREDICT_CAP_S + FORGET_AFTER_S
    #: a track and a blob this close (m) are associated
    track_gate_m: float = GATE_M
    #: a track that should have been seen but was not is dropped after this long (s)
    track_forget_s: float = FORGET_AFTER_S
    blob_stride: int = 2
    blob_min_points: int = 20
    #: depth points less than this (m) above the estimated ground are ground
    ground_tolerance_m: float = 0.25
    max_range_m: float = 30.0
    # hard limit (hard_limit.py): human motion bounds and margins
    #: ISO 13855 walking approach speed (m/s)
    human_max_speed_mps: float = 1.6
    human_step_speed_mps: float = 0.5
    human_max_accel_mps2: float = 2.0
    human_speed_error_mps: float = 0.3
    #: tracks seen within this time (s) enter the gate one by one; older ones only while they
    #: cannot have left the coverage (hard_limit.lost_inside), else the untracked bound covers them
    recent_observation_s: float = 0.5
    #: horizontal error (m) of the landing point: position tracking plus body half-depth
    landing_xy_margin_m: float = 0.25
    #: extra time (s) on top of the descent profile's duration (tracking lag)
    descent_time_margin_s: float = 0.2
    #: the sim's touchdown detection needs this long (s) low and slow
    touchdown_dwell_s: float = 0.3
    #: downward camera's detector: blobs sampled every this many pixels, kept from this many points
    #: (finer than the forward camera's: a person seen from above covers few pixels)
    down_blob_stride: int = 1
    down_blob_min_points: int = 6
    #: the smallest upright torso the coverage guarantee protects (coverage.PersonTorso; m)
    coverage_torso_radius_m: float = 0.10
    coverage_torso_bottom_m: float = 0.9
    coverage_torso_top_m: float = 1.25
    #: downward frames arrive this often (s) (the untracked bound adds one period)
    coverage_frame_period_s: float = 0.2
    #: without a downward camera the untracked bound cannot be shown: never descend
    require_coverage: bool = True
    # landing
    cruise_altitude_m: float = 3.5
    max_altitude_m: float = 10.0
    landing_disc_radius_m: float = 0.8
    #: still obstacles' footprints keep this clearance (m) from the landing disc
    landing_clearance_m: float = 0.5
    align_radius_m: float = 0.35
    #: final descent: sink up to this speed (m/s), accelerating / flaring at these rates (m/s²)
    descent_speed_mps: float = 3.0
    descent_accel_mps2: float = 5.0
    descent_brake_mps2: float = 5.0
    descent_touchdown_speed_mps: float = 0.3
    #: below this height (m) a descent whose landing disc became blocked (a thing moving onto the
    #: pad, no possible person at risk) is finished rather than aborted; people are the hard
    #: limit's (landing.py: the way out that keeps them farther)
    commit_height_m: float = 0.6
    touchdown_height_m: float = 0.12
    #: climbing out (only when quicker out of reach than finishing: landing.py): up at this speed (m/s)
    climb_speed_mps: float = 1.5
    #: holding: turn toward the nearest possible person at up to this yaw rate (rad/s), else
    #: turn slowly to look all around; approaching: turn along the path at this rate
    hold_yaw_rate_rps: float = 1.0
    #: approaching: wait on the path while the way ahead is outside the forward camera's
    #: view (look_ahead.py); off flies the path while the camera is still turning
    look_before_flying: bool = True
    scan_yaw_rate_rps: float = 0.5

    @model_validator(mode="after")
    def _check_torso(self) -> PlannerSettings:
        if not self.ground_tolerance_m < self.coverage_torso_bottom_m < self.coverage_torso_top_m:
            raise ValueError("coverage torso: need ground_tolerance_m < coverage_torso_bottom_m < coverage_torso_top_m "
                             f"(got {self.ground_tolerance_m}, {self.coverage_torso_bottom_m}, "
                             f"{self.coverage_torso_top_m}): torso points must not be taken for ground")
        return self

    @property
    def coverage_torso(self) -> PersonTorso:
        """The torso model of the downward camera's coverage guarantee (coverage.py)."""
        return PersonTorso(self.coverage_torso_radius_m, self.coverage_torso_bottom_m, self.coverage_torso_top_m)
