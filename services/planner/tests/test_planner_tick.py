"""Planner ticks: a regression test for a closed-loop bug, and yaw through ±π."""

import math

import numpy as np
from llmland_planner.planner import Planner
from llmland_planner.settings import PlannerSettings
from llmland_schemas import MissionGoal, VehicleState


def _state(pos, yaw=0.0, t=0.0, seq=0):
    return VehicleState(stamp=t, seq=seq, position_m=pos, velocity_mps=(0, 0, 0), quat_xyzw=(0, 0, 0, 1),
                        euler_rpy_rad=(0.0, 0.0, yaw), body_rates_rps=(0, 0, 0), episode_id="e")


def test_mpc_floor_is_the_ground_not_the_raised_hover_goal():
    """The MPC floor was the goal altitude: below a raised hover point every QP leaned on slack."""
    pl = Planner(PlannerSettings(cruise_altitude_m=5.2))
    pl.start(MissionGoal(episode_id="e", method="baseline", start_m=(0, -9, 2.7), target_m=(0, 0, 0)))
    out = pl.tick(_state((0.0, -9.0, 2.7)))
    assert out.mpc is not None and out.mpc.ok
    assert out.mpc.max_slack < 0.05
    assert np.all(np.abs(out.body_rates_rps[:2]) < 5.0)


def test_yaw_reference_takes_the_short_way_through_pi():
    """Heading across ±π turns the short way (the planner wraps the reference; the MPC does too)."""
    pl = Planner()
    pl.start(MissionGoal(episode_id="e", method="baseline", start_m=(9.0, -0.05, 3.0), target_m=(0, 0, 0)))
    assert pl._yaw_ref > 3.0  # bearing to the target ≈ +π
    out = pl.tick(_state((9.0, -0.05, 3.0), yaw=-math.pi + 0.02))
    assert out.mpc is not None and out.mpc.ok
    assert out.body_rates_rps[2] < 0.5  # the short way is a small negative turn, not +2π − ε


def test_failed_searches_in_a_row_double_the_next_budget(monkeypatch):
    """A failed search used to be retried with the same budget for ever (the drone held at its
    start for the whole episode when the way around a wide crown needed ~1000 expansions)."""
    import llmland_planner.replanning as planner_module

    budgets: list[int] = []

    def failing_plan(pos, vel, goal, regions, cfg):
        budgets.append(cfg.max_expansions)
        return None

    monkeypatch.setattr(planner_module, "plan", failing_plan)
    settings = PlannerSettings()
    pl = Planner(settings)
    pl.start(MissionGoal(episode_id="e", method="baseline", start_m=(0, -9, 3.5), target_m=(0, 0, 0),
                         clock="lockstep"))
    pos, vel, goal = np.array([0.0, -9.0, 3.5]), np.zeros(3), np.array([0.0, 0.0, 3.5])
    t = 0.0
    while t < 3.0:
        pl.paths.maybe_replan(t, pos, vel, goal, [], z_floor_m=0.0)
        t += settings.search_budget_s
    base = settings.search_max_expansions
    cap = base * 2 ** planner_module.SEARCH_BUDGET_DOUBLINGS
    assert budgets[:6] == [base, 2 * base, 4 * base, 8 * base, cap, cap]


def test_failures_at_the_full_budget_are_retried_once_per_replan_period(monkeypatch):
    """Back-to-back searches at ×16 budget made a lockstep episode take half an hour of wall time."""
    import llmland_planner.replanning as planner_module

    starts: list[float] = []
    clock = {"t": 0.0}

    def failing_plan(pos, vel, goal, regions, cfg):
        starts.append(clock["t"])
        return None

    monkeypatch.setattr(planner_module, "plan", failing_plan)
    settings = PlannerSettings()
    pl = Planner(settings)
    pl.start(MissionGoal(episode_id="e", method="baseline", start_m=(0, -9, 3.5), target_m=(0, 0, 0),
                         clock="lockstep"))
    pos, vel, goal = np.array([0.0, -9.0, 3.5]), np.zeros(3), np.array([0.0, 0.0, 3.5])
    while clock["t"] < 6.0:
        pl.paths.maybe_replan(clock["t"], pos, vel, goal, [], z_floor_m=0.0)
        clock["t"] += settings.search_budget_s
    escalating = planner_module.SEARCH_BUDGET_DOUBLINGS + 1
    gaps = np.diff(starts[escalating:])
    assert len(gaps) >= 2 and np.all(gaps >= settings.replan_period_s - 1e-9)


def test_approaching_the_camera_looks_along_a_detour_not_at_the_goal():
    """Conservative open_field seed 34 flew backwards along a detour into a tree it had never seen:
    the forward camera faced the goal while the path led away from it."""
    from llmland_planner.landing import Phase, Surroundings
    from llmland_planner.path import Path
    from llmland_planner.replanning import ActivePlan

    pl = Planner()
    pl.start(MissionGoal(episode_id="e", method="baseline", start_m=(0, 0, 3), target_m=(10, 0, 0)))
    assert abs(pl._yaw_ref) < 1e-9  # facing the goal (+x) before any plan
    # A detour leaving backwards (-x), then around to the goal.
    t = np.arange(0.0, 10.0, 0.05)
    xs = np.where(t < 5.0, -t, -5.0 + 3.0 * (t - 5.0))
    ys = np.where(t < 5.0, 0.0, 2.0 * (t - 5.0))
    p = np.column_stack([xs, ys, np.full_like(t, 3.0)])
    pl.paths.active = ActivePlan(Path(t, p, np.gradient(p, t, axis=0)), [], np.array([10.0, 0, 3]), 0.0, 1.0)
    around = Surroundings([], [], 0.0, lambda _d: [])
    pos, goal = np.array([0.0, 0.0, 3.0]), np.array([10.0, 0.0, 3.0])
    for k in range(1, 80):  # 4 s at 20 Hz: enough to turn π at the hold yaw rate
        pl._steer_yaw(Phase.APPROACH, 0.05 * k, pos, goal, around)
    assert abs(math.remainder(pl._yaw_ref - math.pi, 2 * math.pi)) < 0.05  # looking where it flies: -x
    pl.paths.active = None  # no plan: back to the goal
    for k in range(80, 160):
        pl._steer_yaw(Phase.APPROACH, 0.05 * k, pos, goal, around)
    assert abs(math.remainder(pl._yaw_ref, 2 * math.pi)) < 0.05


def test_look_ahead_is_the_path_end_near_the_goal():
    from llmland_planner.path import Path
    from llmland_planner.replanning import ActivePlan

    pl = Planner()
    t = np.arange(0.0, 1.0, 0.05)
    p = np.column_stack([t, np.zeros_like(t), np.full_like(t, 3.0)])
    assert pl.paths.look_ahead_m(np.zeros(3), 3.0) is None
    pl.paths.active = ActivePlan(Path(t, p, np.gradient(p, t, axis=0)), [], p[-1], 0.0, 1.0)
    assert np.allclose(pl.paths.look_ahead_m(np.zeros(3), 3.0), p[-1])
    assert np.allclose(pl.paths.look_ahead_m(np.zeros(3), 0.5), p[10])
