"""The coverage assumption of the hard limit, against real renders: wherever the planner's
coverage radius says a person is detected, the sim's downward camera and the planner's detector
do detect them (services/planner/llmland_planner/coverage.py; the closed loop once let a person
the detector missed right below the hover near the pad)."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from llmland_planner.coverage import detection_radius_m
from llmland_planner.settings import PlannerSettings
from llmland_schemas import MissionGoal
from llmland_schemas.depth import find_blobs
from llmland_sim.settings import SimSettings
from llmland_sim.simulation import Simulation

#: a detection is the person's when its bounds centre is this close (m) to their axis
SAME_PERSON_M = 0.8
HEIGHTS_M = (3.0, 3.5, 4.0)
FRACTIONS = (0.0, 0.3, 0.6, 0.85, 1.0)


@pytest.fixture(scope="module")
def sim() -> Simulation:
    logging.getLogger("llmland_sim").setLevel(logging.WARNING)
    return Simulation(SimSettings())


@pytest.mark.parametrize(("world", "seed", "bearing_deg"), [("open_field", 3, 0.0), ("open_field", 5, 45.0),
                                                           ("urban", 2, 90.0)])
def test_everyone_within_the_coverage_radius_is_detected(sim: Simulation, world: str, seed: int,
                                                         bearing_deg: float) -> None:
    ps = PlannerSettings()
    mission = MissionGoal(episode_id="cov", method="baseline", world=world, seed=seed, target_m=(0.0, 0.0, 0.0))
    sim.reset(mission)
    person = next(o for o in sim.world.objects if o.cls == "person")
    base = np.asarray(person.position(), dtype=float)
    direction = np.array([math.cos(math.radians(bearing_deg)), math.sin(math.radians(bearing_deg))])
    checked = 0
    for h in HEIGHTS_M:
        sim.reset(mission.model_copy(update={"start_m": (float(base[0]), float(base[1]), float(base[2] + h))}))
        k = sim.render_frame(camera="down").header.intrinsics
        radius = detection_radius_m(k, h, 0.0, stride=ps.down_blob_stride, min_points=ps.down_blob_min_points,
                                    torso=ps.coverage_torso)
        assert radius > 0.0, f"no coverage at {h} m"
        for f in FRACTIONS:
            xy = base[:2] + f * radius * direction
            sim.reset(mission.model_copy(update={"start_m": (float(xy[0]), float(xy[1]), float(base[2] + h))}))
            frame = sim.render_frame(camera="down")
            blobs = find_blobs(frame.depth_m, frame.header.intrinsics, frame.T_world_camera,
                               stride=ps.down_blob_stride, min_points=ps.down_blob_min_points,
                               max_range_m=ps.max_range_m, ground_tol_m=ps.ground_tolerance_m,
                               ground_height_fn=lambda x, y: np.full(np.shape(x), base[2]))
            found = [b for b in blobs if np.linalg.norm(b.centroid_m[:2] - base[:2]) < SAME_PERSON_M]
            assert found, f"{world} seed {seed}: person {f * radius:.2f} m off the vertical at {h} m not detected"
            checked += 1
    assert checked == len(HEIGHTS_M) * len(FRACTIONS)
