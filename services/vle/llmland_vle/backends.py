"""The captioner backends' factory, beside the backends: ``simcap`` (:mod:`.simcap`),
``blip`` (:mod:`.blip`) and ``oracle`` (:mod:`.oracle`), each imported only when picked."""

from __future__ import annotations

from .captioner import Captioner
from .settings import VleSettings


def make_captioner(settings: VleSettings) -> Captioner:
    """The backend named by ``settings.backend`` (simcap, blip or oracle)."""
    if settings.backend == "simcap":
        from .simcap.backend import SimcapCaptioner

        return SimcapCaptioner(settings.model_path, threads=settings.threads, crop_size=settings.crop_size)
    if settings.backend == "blip":
        from .blip import BlipCaptioner

        if settings.model_path is None:
            raise ValueError("the blip backend needs LLMLAND_VLE_MODEL_PATH (a local BLIP directory)")
        return BlipCaptioner(settings.model_path, threads=settings.threads)
    if settings.backend == "oracle":
        from .oracle import OracleCaptioner

        return OracleCaptioner(noise=settings.oracle_noise, seed=settings.oracle_seed)
    raise ValueError(f"unknown captioner backend {settings.backend!r}")
