"""Specs on the planner side: typed on tracks, read without side effects, is_dynamic passed through."""

import numpy as np
from llmland_planner.regions import from_obstacle
from llmland_planner.settings import PlannerSettings
from llmland_planner.specs import AttachedSpec
from llmland_planner.world_model import WorldModel
from llmland_schemas import ObjectSpec, SafetySpec, SafetySpecMessage
from llmland_schemas.depth import Blob


def _blob(x: float, y: float, h: float = 1.7) -> Blob:
    lo, hi = np.array([x - 0.25, y - 0.25, 0.0]), np.array([x + 0.25, y + 0.25, h])
    return Blob(blob_id=0, centroid_m=(lo + hi) / 2, mean_m=(lo + hi) / 2, lo_m=lo, hi_m=hi, size_m=hi - lo,
                n_points=100, bbox_px=(0, 0, 10, 10), footprint_radius_m=0.35)


def _person(stamp: float) -> SafetySpecMessage:
    spec = SafetySpec(is_dynamic=True, z_min=3.0, buffer_m=3.0, label="person", source="rag")
    return SafetySpecMessage(stamp=stamp, scene=spec, latency_ms=0.0,
                             objects=[ObjectSpec(obj_id="b0", centroid_m=(5.0, 0.0, 0.85), size_m=(0.5, 0.5, 1.7),
                                                 spec=spec)])


def test_reading_regions_releases_nothing() -> None:
    wm = WorldModel(PlannerSettings(), "llm-land")
    wm.tracker.update([_blob(5.0, 0.0)], 0.0)
    wm.on_spec(_person(0.0))
    version = wm.version
    for _ in range(2):
        assert all(r.label != "person" for r in wm.regions(1.0))
        wm.landing_regions(1.0, 2.0)
        wm.people(1.0)
    assert len(wm.pending) == 1 and wm.specs_applied == 0 and wm.version == version


def test_a_released_spec_is_a_typed_field_of_the_track() -> None:
    wm = WorldModel(PlannerSettings(), "llm-land")
    wm.tracker.update([_blob(5.0, 0.0)], 0.0)
    wm.on_spec(_person(0.0))
    wm.release_specs(0.5)
    (track,) = wm.tracker.tracks()
    assert isinstance(track.spec, AttachedSpec)
    assert track.spec.spec.label == "person" and track.spec.applied_s == 0.5
    assert abs(track.spec.height_m - 1.7) < 1e-9
    assert "spec" not in track.meta


def test_from_obstacle_takes_is_dynamic() -> None:
    still = from_obstacle((0.0, 0.0), 0.3, 1.7, 3.0, 3.0)
    person = from_obstacle((0.0, 0.0), 0.3, 1.7, 3.0, 3.0, is_dynamic=True)
    swept = from_obstacle((0.0, 0.0), 0.3, 1.7, 3.0, 3.0, velocity_xy=(1.0, 0.0), horizon_s=1.0)
    assert [r.is_dynamic for r in still] == [False]
    assert [r.is_dynamic for r in person] == [True]
    assert len(swept) > 1 and all(r.is_dynamic for r in swept)
