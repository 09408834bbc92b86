"""Simulator settings, read once from ``LLMLAND_SIM_*`` environment variables."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict


class SimSettings(BaseSettings):
    """Everything the sim service reads. Rates in Hz, durations in seconds."""

    model_config = SettingsConfigDict(env_prefix="LLMLAND_SIM_", extra="ignore")

    drone_id: str = "d0"
    physics_hz: int = 300
    ctrl_hz: int = 50
    camera_hz: float = 5.0  # 0 disables the camera
    camera_width: int = 384
    camera_height: int = 384
    #: forward-down camera: pitch below the body x axis (90° would look straight down)
    camera_pitch_down_deg: float = 60.0
    #: downward landing camera (RGB-D, straight down, wide angle): published on
    #: ``sim/camera_down`` at this rate (0 disables), rendered with the forward camera's frames
    down_camera_hz: float = 5.0
    down_camera_size: int = 400
    #: full field of view (deg) of the square downward image: 140° sees the ground up to
    #: 2.7 × the height around the vehicle (the planner's coverage argument, DESIGN §6)
    down_camera_fov_deg: float = 140.0
    renderer: Literal["auto", "tiny", "egl"] = "auto"
    truth_hz: float = 10.0
    gui: bool = False
    #: Lockstep: wall time to wait for the command echoing a tick's seq before asking whether the
    #: planner is still alive (then the wait goes on, see ``lockstep_max_wait_s``). Lockstep trades
    #: wall time for reproducibility: a planner tick that waits for its search worker on a loaded
    #: machine can take seconds (load average 4 on 2 cores: a 1 s limit made seeded runs diverge;
    #: 9.7 s for a search at its largest budget beside other episodes); overruns are still counted
    #: from the command's ``tick_ms``.
    lockstep_timeout_s: float = 10.0
    #: Lockstep: past ``lockstep_timeout_s`` the sim waits on, while the planner's liveliness
    #: token is up, up to this much wall time (s) in all: a slow tick (a search at its largest
    #: budget on a loaded machine) must not change the episode; a hung planner ends the wait here.
    lockstep_max_wait_s: float = 300.0
    #: Lockstep with perception: a frame's spec not received within this wall time (s) is
    #: abandoned and perception counts as degraded (VLE or reasoner down) until one arrives
    perception_timeout_s: float = 15.0
    #: Hold the last command this long (sim time) before the vehicle-side failsafe.
    command_hold_s: float = 0.2
    #: The failsafe holds no lower than this (m) over the ground: above people's reach (people
    #: here are 1.7 m tall; plus the 1 m hard limit, plus 0.8 m for a taller person and sag).
    failsafe_min_height_m: float = 3.5
    #: Record every episode to this .rrd (may contain ``{episode_id}``) ...
    rrd: Path | None = None
    #: ... or stream live to a Rerun viewer, e.g. ``rerun+http://127.0.0.1:9876/proxy``.
    rerun_connect: str | None = None

    @model_validator(mode="after")
    def _check_rates(self) -> SimSettings:
        if self.physics_hz < 240:
            raise ValueError("physics_hz must be >= 240")
        if self.ctrl_hz <= 0 or self.physics_hz % self.ctrl_hz:
            raise ValueError(f"physics_hz ({self.physics_hz}) must be an integer multiple of ctrl_hz ({self.ctrl_hz})")
        return self

    @property
    def substeps(self) -> int:
        """Physics steps per control tick."""
        return self.physics_hz // self.ctrl_hz
