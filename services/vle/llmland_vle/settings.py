"""VLE settings, read once from ``LLMLAND_VLE_*`` environment variables.

Example: ``LLMLAND_VLE_BACKEND=blip LLMLAND_VLE_MODEL_PATH=/models/blip-base llmland-vle``.
The bus is configured separately (``ZENOH_*``, see :mod:`llmland_schemas.bus`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal, Self

from pydantic import Field, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict


class VleSettings(BaseSettings):
    """Everything the VLE service reads."""

    model_config = SettingsConfigDict(env_prefix="LLMLAND_VLE_", extra="ignore")

    drone_id: str = "d0"
    #: simcap (default, trained here), blip (local BLIP v1 directory) or oracle (sim truth)
    backend: Literal["simcap", "blip", "oracle"] = "simcap"
    #: simcap: weights directory (default: the committed weights); blip: the local model directory
    model_path: Path | None = None
    #: oracle: probability that a caption is corrupted (synonym, omission or wrong word)
    oracle_noise: Annotated[float, Field(ge=0.0, le=1.0)] = 0.0
    oracle_seed: int = 0
    #: caption at most this many blobs a frame (the largest first)
    max_objects: Annotated[int, Field(ge=0, le=256)] = 12
    #: side (px) crops are resized to before captioning
    crop_size: Annotated[int, Field(ge=16, le=1024)] = 96
    #: torch CPU threads. One: the VLE shares the CPU with the planner and the sim (a drone's
    #: companion computer, or this machine's 2 cores). There a second torch thread waits at every
    #: layer for a core that another process holds: in a lockstep episode on 2 cores a frame took
    #: 18.8 ms with 2 threads and 12.9 ms with 1 (simcap). Alone, 2 threads gain ≈ 5 %; raise it
    #: on a machine with cores to spare, and for ``blip`` (measured with simcap only).
    threads: Annotated[int, Field(ge=1, le=64)] = 1
    #: depth blobs: pixel stride and range, as the planner uses them
    blob_stride: Annotated[int, Field(ge=1, le=8)] = 2
    max_range_m: Annotated[float, Field(gt=0.0)] = 30.0
    #: frames outside this size (px a side) are dropped as malformed
    min_frame_px: Annotated[int, Field(ge=8)] = 32
    max_frame_px: Annotated[int, Field(ge=8)] = 4096
    #: queryable: largest accepted image payload (bytes)
    max_image_bytes: Annotated[int, Field(ge=1024)] = 16 * 1024 * 1024

    @model_validator(mode="after")
    def _check(self) -> Self:
        if self.min_frame_px > self.max_frame_px:
            raise ValueError("min_frame_px must not exceed max_frame_px")
        return self
