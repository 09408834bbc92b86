"""The layout a landing recording opens with: the 3D world large, the cameras with their
blobs, a small depth view, the time series and a log of captions, specs and phases.

Sent with every recording (``RecordingStream.send_blueprint``), so the viewer never has to
guess a layout.
"""

from __future__ import annotations

import numpy as np
import rerun.blueprint as rrb

from . import paths

#: the 3D eye looks at the landing zone from this far (m, horizontally) ...
EYE_DISTANCE_M = 10.0
#: ... this high above the target (m) ...
EYE_HEIGHT_M = 6.5
#: ... from this far around from the approach direction (rad), so the path is seen side-on
EYE_AZIMUTH_RAD = np.deg2rad(50.0)
#: the eye looks this fraction of the way from the target toward the start
LOOK_TOWARD_START = 0.2
#: grid spacing of the 3D ground (m)
GRID_SPACING_M = 1.0
#: y range (m) of the person-distance plot: the interesting part is near the 1 m limit
PERSON_PLOT_MAX_M = 8.0


def landing_eye(start_m: np.ndarray, target_m: np.ndarray) -> rrb.EyeControls3D:
    """An orbit eye on the landing zone, turned off the approach line so the descent is seen."""
    approach = np.asarray(start_m[:2], dtype=float) - np.asarray(target_m[:2], dtype=float)
    heading = float(np.arctan2(approach[1], approach[0])) if np.linalg.norm(approach) > 1e-6 else 0.0
    az = heading + EYE_AZIMUTH_RAD
    look = np.asarray(target_m, dtype=float).copy()
    look[:2] += LOOK_TOWARD_START * approach
    eye = look + np.array([EYE_DISTANCE_M * np.cos(az), EYE_DISTANCE_M * np.sin(az), EYE_HEIGHT_M])
    return rrb.EyeControls3D(kind=rrb.Eye3DKind.Orbital, position=eye.tolist(), look_target=look.tolist(),
                             eye_up=[0.0, 0.0, 1.0])


def landing_blueprint(eye: rrb.EyeControls3D | None = None) -> rrb.Blueprint:
    """Left: the world (3 shares) over the text log; right: cameras, depth and caption, plots."""
    world = rrb.Spatial3DView(origin=paths.WORLD, name="world", eye_controls=eye,
                              line_grid=rrb.LineGrid3D(spacing=GRID_SPACING_M))
    cameras = rrb.Horizontal(
        rrb.Spatial2DView(origin=paths.CAMERA_RGB, name="forward camera"),
        rrb.Spatial2DView(origin=paths.CAMERA_DOWN_RGB, name="downward camera"),
    )
    depth_and_caption = rrb.Horizontal(
        rrb.Spatial2DView(origin=paths.CAMERA_DEPTH, name="forward depth"),
        rrb.TextDocumentView(origin=paths.SCENE_CAPTION, name="caption"),
        column_shares=[1, 2],
    )
    plots = rrb.Grid(
        rrb.TimeSeriesView(origin=paths.PLOT_ALTITUDE, name="altitude (m)"),
        rrb.TimeSeriesView(origin=paths.PLOT_PERSON, name="closest person (m)",
                           axis_y=rrb.ScalarAxis(range=(0.0, PERSON_PLOT_MAX_M))),
        rrb.TimeSeriesView(origin=paths.PLOT_SPEC_LATENCY, name="spec latency (ms)"),
        rrb.TimeSeriesView(origin="plot", contents=[paths.PLOT_MPC_SOLVE, paths.PLOT_SEARCH],
                           name="MPC solve / search (ms)"),
        grid_columns=2,
    )
    log = rrb.TextLogView(origin=paths.LOG, name="captions · specs · phases")
    layout = rrb.Horizontal(
        rrb.Vertical(world, log, row_shares=[3, 1]),
        rrb.Vertical(cameras, depth_and_caption, plots, row_shares=[2, 1, 2]),
        column_shares=[3, 2],
    )
    return rrb.Blueprint(
        layout,
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=paths.TIMELINE, state="collapsed", play_state="playing", loop_mode="all"),
    )
