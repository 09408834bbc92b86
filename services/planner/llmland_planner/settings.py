"""Planner settings, read once from ``LLMLAND_PLANNER_*`` environment variables."""

from __future__ import annotations

from pydantic_settings import BaseSettings, SettingsConfigDict


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
    # semantics
    baseline_margin_m: float = 1.0
    spec_match_m: float = 1.5
    spec_stale_s: float = 8.0
    moving_speed_mps: float = 0.25
    moving_displacement_m: float = 1.0
    #: out of view: constant-velocity prediction is trusted this long (s) ...
    predict_cap_s: float = 1.0
    #: ... then a dynamic obstacle's buffer grows at this speed (m/s), up to this much (m)
    unseen_growth_mps: float = 1.0
    unseen_growth_max_m: float = 3.0
    # landing
    cruise_altitude_m: float = 3.0
    max_altitude_m: float = 10.0
    landing_disc_radius_m: float = 0.8
    align_radius_m: float = 0.35
    #: descent: sink rate √(2·brake·h) within [min, max] (m/s): fast high up, soft at the ground
    descent_speed_mps: float = 1.2
    descent_min_speed_mps: float = 0.3
    descent_brake_mps2: float = 0.8
    #: below this height (m) a started descent is finished rather than aborted
    commit_height_m: float = 0.5
    #: how fast (m/s) a person or vehicle may close in unseen while the drone descends
    reach_speed_mps: float = 1.5
    touchdown_height_m: float = 0.12
    hold_clear_s: float = 0.5
    #: yaw rate while holding and descending, so the forward-down camera sees all around
    scan_yaw_rate_rps: float = 1.0
    #: yaw swept (rad) in each hold before a descent: 360° less the camera's 90° field of view
    scan_sweep_rad: float = 4.8
    #: perception
    blob_stride: int = 2
    max_range_m: float = 30.0
