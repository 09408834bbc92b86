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
    descent_speed_mps: float = 0.5
    touchdown_height_m: float = 0.12
    hold_clear_s: float = 0.5
    #: yaw rate while holding and descending, so the forward-down camera sees all around
    scan_yaw_rate_rps: float = 0.6
    #: perception
    blob_stride: int = 2
    max_range_m: float = 30.0
