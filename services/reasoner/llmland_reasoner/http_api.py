"""The ground station's HTTP API (FastAPI): image or caption in, SafetySpec out; the KB.

- ``POST /v1/spec``   multipart image (PNG/JPEG) → SafetySpec (caption via the VLE queryable)
- ``POST /v1/reason`` ``{"caption": "...", "mode": optional}`` → SafetySpec
- ``GET /v1/kb``, ``POST /v1/kb`` read and extend the knowledge base (validated, persisted)
- ``GET /healthz``    liveness and loaded model names

Bad input gets a 4xx with a message and never reaches the bus. With ``api_token`` set,
every route but ``/healthz`` needs ``Authorization: Bearer <token>``.
"""

from __future__ import annotations

import json
import logging
import secrets
from collections.abc import Awaitable, Callable
from typing import Annotated, Any

from fastapi import Depends, FastAPI, File, Header, HTTPException, Request, Response, UploadFile
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from llmland_schemas import Caption, SafetySpec
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from starlette.concurrency import run_in_threadpool

from .engine import ReasonerEngine
from .kb import KbEntry, KbEntryExistsError
from .settings import Mode, ReasonerSettings
from .upload import CaptionFailedError, CaptionRefusedError, check_image, json_body_problem

log = logging.getLogger(__name__)

#: image bytes → the VLE's caption, None when no VLE answered; raises
#: :class:`~.upload.CaptionRefusedError` when the VLE answered that it cannot caption the image
CaptionFn = Callable[[bytes], Caption | None]
#: Routes whose body is JSON: checked for UTF-8, JSON and lone surrogates before FastAPI parses it.
JSON_ROUTES = frozenset({"/v1/reason", "/v1/kb"})
#: The largest JSON body accepted (bytes): a caption is at most 1000 characters, a KB entry ~1 kB.
MAX_JSON_BYTES = 64 * 1024


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


class AsciiJSONResponse(JSONResponse):
    """JSON with every non-ASCII character escaped: a lone surrogate echoed back cannot break it."""

    def render(self, content: Any) -> bytes:
        return json.dumps(content, ensure_ascii=True, allow_nan=False, separators=(",", ":")).encode("ascii")


def _error_list(exc: RequestValidationError) -> list[dict[str, Any]]:
    """The validation errors without the offending input (it may be bytes or not Unicode)."""
    return [{"type": str(e.get("type", "")), "loc": [str(x) for x in e.get("loc", ())], "msg": str(e.get("msg", ""))}
            for e in exc.errors()]


def create_app(engine: ReasonerEngine, caption_fn: CaptionFn, settings: ReasonerSettings) -> FastAPI:
    """The reasoner's HTTP API (OpenAPI at ``/docs``): health, specs from captions and images, the KB."""
    app = FastAPI(title="LLM-Land reasoner", version="0.1.0", default_response_class=AsciiJSONResponse,
                  description="Captions and images to drone-landing safety specs (RAG + local LLM).")
    _install_input_checks(app)
    guarded = [Depends(_bearer_auth(settings))]
    _add_spec_routes(app, engine, caption_fn, settings, guarded)
    _add_kb_routes(app, engine, guarded)
    return app


def _install_input_checks(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def invalid(_request: Request, exc: RequestValidationError) -> Response:
        return AsciiJSONResponse({"detail": _error_list(exc)}, status_code=422)

    @app.middleware("http")
    async def json_bodies(request: Request, call_next: Callable[[Request], Awaitable[Response]]) -> Response:
        """JSON routes: 415 for another content type (multipart, an image), 413 over
        :data:`MAX_JSON_BYTES`, 422 for a body that is not UTF-8 JSON or holds a lone surrogate;
        nothing malformed reaches a handler."""
        if request.method == "POST" and request.url.path in JSON_ROUTES:
            ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
            if ctype != "application/json":
                return AsciiJSONResponse({"detail": f"send application/json, not {ctype or 'no content type'}"},
                                         status_code=415)
            declared = request.headers.get("content-length", "")
            if declared.isdigit() and int(declared) > MAX_JSON_BYTES:
                return AsciiJSONResponse({"detail": f"JSON body over {MAX_JSON_BYTES} bytes"}, status_code=413)
            body = await request.body()
            if len(body) > MAX_JSON_BYTES:
                return AsciiJSONResponse({"detail": f"JSON body over {MAX_JSON_BYTES} bytes"}, status_code=413)
            problem = json_body_problem(body)
            if problem is not None:
                return AsciiJSONResponse({"detail": problem}, status_code=422)
        return await call_next(request)


def _bearer_auth(settings: ReasonerSettings) -> Callable[..., None]:
    """The dependency checking ``Authorization: Bearer <api_token>`` (a no-op without a token)."""
    token = settings.api_token.get_secret_value() if settings.api_token else None

    def auth(authorization: Annotated[str | None, Header()] = None) -> None:
        if token is None:
            return
        scheme, _, given = (authorization or "").strip().partition(" ")
        # header values arrive as latin-1 text: compare their bytes (compare_digest refuses non-ASCII
        # str), with the scheme case-insensitive (RFC 7235 §2.1)
        if scheme.lower() != "bearer" or not secrets.compare_digest(
                given.strip().encode("latin-1", "replace"), token.encode("utf-8")):
            raise HTTPException(401, "missing or wrong API token (Authorization: Bearer <token>)")

    return auth


def _add_spec_routes(app: FastAPI, engine: ReasonerEngine, caption_fn: CaptionFn, settings: ReasonerSettings,
                     guarded: list[Any]) -> None:
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
              responses={503: {"description": "no captioning (VLE) service answered"},
                         502: {"description": "the VLE failed to caption the image"}})
    async def spec(image: Annotated[UploadFile, File(description="PNG or JPEG")]) -> SafetySpec:
        data = await image.read(settings.max_upload_bytes + 1)
        # decoding, the VLE query (up to its timeout) and the extraction block: off the event loop,
        # or one slow caption holds every other request, /healthz included
        return await run_in_threadpool(_spec_of, data)

    def _spec_of(data: bytes) -> SafetySpec:
        check_image(data, settings.max_upload_bytes)
        try:
            caption = caption_fn(data)
        except CaptionRefusedError as exc:
            raise HTTPException(422, f"the VLE cannot caption this image: {exc}") from None
        except CaptionFailedError as exc:
            raise HTTPException(502, f"the VLE failed to caption the image: {exc}") from None
        if caption is None:
            raise HTTPException(503, "no VLE service answered on llmland/@ground/vle/caption: start llmland-vle")
        result = engine.extract(caption.text)
        return result.model_copy(update={"latency_ms": result.latency_ms + caption.latency_ms})


def _add_kb_routes(app: FastAPI, engine: ReasonerEngine, guarded: list[Any]) -> None:
    @app.get("/v1/kb", response_model=KbView, dependencies=guarded, tags=["kb"])
    def get_kb() -> KbView:
        kb = engine.resources.kb
        return KbView(version=kb.version, entries=kb.entries)

    @app.post("/v1/kb", response_model=KbEntry, status_code=201, dependencies=guarded, tags=["kb"])
    def add_kb(entry: dict[str, Any]) -> KbEntry:
        try:
            # replace=False: a write that replaced an entry could turn "pedestrian" into a bench
            # (the category rules check the entry, not what it replaces); changing a shipped entry
            # is an edit of the KB file, reviewed like code. Checked where the write happens, so
            # two concurrent POSTs of one id cannot both pass.
            return engine.add_entry(KbEntry.model_validate(entry), replace=False)
        except KbEntryExistsError as exc:
            raise HTTPException(409, f"{exc}; the API adds entries, it does not replace them "
                                     "(edit the KB file to change one)") from None
        except ValidationError as exc:
            reasons = "; ".join(f"{'.'.join(str(x) for x in e.get('loc', ())) or 'entry'}: {e.get('msg', '')}"
                                for e in exc.errors(include_url=False))
            raise HTTPException(422, f"invalid KB entry: {reasons}") from None
        except ValueError as exc:
            raise HTTPException(409, str(exc)) from None
