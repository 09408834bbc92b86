"""The ground station's HTTP API (FastAPI): image or caption in, SafetySpec out; the KB.

- ``POST /v1/spec``   multipart image (PNG/JPEG) → SafetySpec (caption via the VLE queryable)
- ``POST /v1/reason`` ``{"caption": "...", "mode": optional}`` → SafetySpec
- ``GET /v1/kb``, ``POST /v1/kb`` read and extend the knowledge base (validated, persisted)
- ``GET /healthz``    liveness and loaded model names

Bad input gets a 4xx with a message and never reaches the bus. With ``api_token`` set,
every route but ``/healthz`` needs ``Authorization: Bearer <token>``.
"""

from __future__ import annotations

import io
import logging
import secrets
from collections.abc import Callable
from typing import Annotated, Any

from fastapi import Depends, FastAPI, File, Header, HTTPException, UploadFile
from llmland_schemas import Caption, SafetySpec
from PIL import Image, UnidentifiedImageError
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from .engine import ReasonerEngine
from .kb import KbEntry
from .settings import Mode, ReasonerSettings

log = logging.getLogger(__name__)

#: image bytes → caption, or None when no captioning service answered
CaptionFn = Callable[[bytes], Caption | None]
IMAGE_MAGIC = {b"\x89PNG\r\n\x1a\n": "PNG", b"\xff\xd8\xff": "JPEG"}
MAX_PIXELS = 4096 * 4096


class ReasonRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    caption: Annotated[str, Field(min_length=1, max_length=1000)]
    mode: Mode | None = None


class KbView(BaseModel):
    version: str
    entries: list[KbEntry]


class Health(BaseModel):
    #: ``ok``, or ``degraded`` while the LLM worker is down (specs are then conservative fallbacks)
    status: str
    mode: str
    models: dict[str, str]
    #: the LLM worker: state (ready / restarting / failed), restarts, crashes, last error
    llm: dict[str, Any] | None = None


def _check_image(data: bytes, limit: int) -> None:
    if not data:
        raise HTTPException(400, "empty upload: send a PNG or JPEG image in the 'image' field")
    if len(data) > limit:
        raise HTTPException(413, f"image of {len(data)} bytes exceeds the limit of {limit} bytes")
    if not any(data.startswith(m) for m in IMAGE_MAGIC):
        raise HTTPException(415, "not a PNG or JPEG image")
    try:
        with Image.open(io.BytesIO(data)) as img:
            if img.width * img.height > MAX_PIXELS:
                raise HTTPException(413, f"image of {img.width}x{img.height} pixels is too large")
            img.verify()
    except HTTPException:
        raise
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
        raise HTTPException(400, f"corrupt image: {exc}") from None


def create_app(engine: ReasonerEngine, caption_fn: CaptionFn, settings: ReasonerSettings) -> FastAPI:
    app = FastAPI(title="LLM-Land reasoner", version="0.1.0",
                  description="Captions and images to drone-landing safety specs (RAG + local LLM).")
    token = settings.api_token.get_secret_value() if settings.api_token else None

    def auth(authorization: Annotated[str | None, Header()] = None) -> None:
        if token is None:
            return
        given = (authorization or "").removeprefix("Bearer ").strip()
        if not secrets.compare_digest(given, token):
            raise HTTPException(401, "missing or wrong API token (Authorization: Bearer <token>)")

    guarded = [Depends(auth)]

    @app.get("/healthz", response_model=Health, tags=["health"])
    def healthz() -> Health:
        status, llm = engine.health()
        return Health(status=status, mode=settings.mode, models=engine.models(), llm=llm)

    @app.post("/v1/reason", response_model=SafetySpec, dependencies=guarded, tags=["spec"])
    def reason(req: ReasonRequest) -> SafetySpec:
        if not req.caption.strip():
            raise HTTPException(422, "caption is blank")
        return engine.extract(req.caption, req.mode)

    @app.post("/v1/spec", response_model=SafetySpec, dependencies=guarded, tags=["spec"],
              responses={503: {"description": "no captioning (VLE) service answered"}})
    async def spec(image: Annotated[UploadFile, File(description="PNG or JPEG")]) -> SafetySpec:
        data = await image.read(settings.max_upload_bytes + 1)
        _check_image(data, settings.max_upload_bytes)
        caption = caption_fn(data)
        if caption is None:
            raise HTTPException(503, "no VLE service answered on llmland/vle/caption: start llmland-vle")
        result = engine.extract(caption.text)
        return result.model_copy(update={"latency_ms": result.latency_ms + caption.latency_ms})

    @app.get("/v1/kb", response_model=KbView, dependencies=guarded, tags=["kb"])
    def get_kb() -> KbView:
        kb = engine.resources.kb
        return KbView(version=kb.version, entries=kb.entries)

    @app.post("/v1/kb", response_model=KbEntry, status_code=201, dependencies=guarded, tags=["kb"])
    def add_kb(entry: dict[str, Any]) -> KbEntry:
        try:
            return engine.add_entry(KbEntry.model_validate(entry))
        except ValidationError as exc:
            raise HTTPException(422, f"invalid KB entry: {exc.errors(include_url=False)}") from None
        except ValueError as exc:
            raise HTTPException(409, str(exc)) from None

    return app
