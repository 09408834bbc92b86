"""Open Zenoh sessions from settings and exchange typed messages over them.

Settings come from the environment (``ZENOH_MODE``, ``ZENOH_CONNECT``, ``ZENOH_LISTEN``,
``ZENOH_CONFIG``). The default is peer mode on loopback with explicit endpoints and
multicast scouting off: a process connects to ``tcp/127.0.0.1:7447`` (the endpoint the
``llmland`` CLI or ``llmland-router`` listens on) and nothing is sent off the machine.

:class:`Bus` wraps a session: typed publishers, subscribers that validate every payload
and count and drop malformed ones (the service stays up), and ``close()`` that always
runs (a callback subscriber left open hangs process exit).
"""

from __future__ import annotations

import json
import logging
import threading
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar

import zenoh
from pydantic import BaseModel, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

from .codec import MessageError, decode, encode

log = logging.getLogger(__name__)
M = TypeVar("M", bound=BaseModel)
T = TypeVar("T")

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"


class ZenohSettings(BaseSettings):
    """How a process joins the bus. Lists accept comma-separated strings."""

    model_config = SettingsConfigDict(env_prefix="ZENOH_", extra="ignore")

    mode: Literal["peer", "client", "router"] = "peer"
    connect: Annotated[list[str], NoDecode] = [DEFAULT_ENDPOINT]
    listen: Annotated[list[str], NoDecode] = []
    config: Path | None = None
    multicast_scouting: bool = False

    @field_validator("connect", "listen", mode="before")
    @classmethod
    def _split(cls, value: Any) -> Any:
        if isinstance(value, str):
            return [v.strip() for v in value.split(",") if v.strip()]
        return value


def make_config(settings: ZenohSettings) -> zenoh.Config:
    """Build a zenoh Config: file (if any) first, then the explicit settings on top."""
    conf = zenoh.Config.from_file(str(settings.config)) if settings.config else zenoh.Config()
    conf.insert_json5("mode", json.dumps(settings.mode))
    conf.insert_json5("scouting/multicast/enabled", json.dumps(settings.multicast_scouting))
    if settings.connect:
        conf.insert_json5("connect/endpoints", json.dumps(settings.connect))
    if settings.listen:
        conf.insert_json5("listen/endpoints", json.dumps(settings.listen))
    return conf


def open_session(settings: ZenohSettings | None = None) -> zenoh.Session:
    """Open a Zenoh session from settings (environment when ``None``)."""
    settings = settings or ZenohSettings()
    zenoh.init_log_from_env_or("error")
    log.debug("opening zenoh session mode=%s connect=%s listen=%s", settings.mode, settings.connect, settings.listen)
    return zenoh.open(make_config(settings))


class Bus:
    """A Zenoh session with typed, validating publish/subscribe helpers.

    Use as a context manager or call :meth:`close`. Subscriber callbacks run on Zenoh's
    threads; keep them short (hand work to a queue).
    """

    def __init__(self, settings: ZenohSettings | None = None, session: zenoh.Session | None = None) -> None:
        self.session = session if session is not None else open_session(settings)
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._handles: list[Any] = []
        self._lock = threading.Lock()
        self.received: Counter[str] = Counter()
        self.dropped: Counter[str] = Counter()
        self._closed = False

    # ------------------------------------------------------------------ publish
    def publisher(self, key: str, *, express: bool = False,
                  encoding: zenoh.Encoding | None = None) -> zenoh.Publisher:
        """The publisher for ``key``, declared on first use (JSON unless told otherwise)."""
        with self._lock:
            pub = self._publishers.get(key)
            if pub is None:
                pub = self.session.declare_publisher(
                    key, encoding=encoding or zenoh.Encoding.APPLICATION_JSON, express=express
                )
                self._publishers[key] = pub
            return pub

    def publish(self, key: str, msg: BaseModel, *, express: bool = False) -> None:
        """Publish a message as JSON on ``key`` (``express``: never batched, for control-loop
        messages whose latency matters more than throughput)."""
        self.publisher(key, express=express).put(encode(msg))

    def publish_bytes(self, key: str, payload: bytes, *, encoding: zenoh.Encoding | None = None) -> None:
        """Publish raw bytes (camera frames)."""
        self.publisher(key, encoding=encoding or zenoh.Encoding.APPLICATION_OCTET_STREAM).put(payload)

    # ------------------------------------------------------------------ subscribe
    def subscribe(self, key: str, model: type[M], callback: Callable[[str, M], None]) -> None:
        """Subscribe with validation: ``callback(key, msg)`` gets only valid messages."""

        def parse(payload: bytes) -> M:
            return decode(model, payload)

        self.subscribe_parsed(key, parse, callback)

    def subscribe_parsed(
        self, key: str, parse: Callable[[bytes], T], callback: Callable[[str, T], None]
    ) -> None:
        """Subscribe with a custom parser; parse errors are logged, counted and dropped."""

        def on_sample(sample: zenoh.Sample) -> None:
            k = str(sample.key_expr)
            self.received[k] += 1
            try:
                msg: T = parse(sample.payload.to_bytes())
            except (MessageError, ValueError) as exc:
                self.dropped[k] += 1
                log.warning("dropped malformed message on %s (%d so far): %s", k, self.dropped[k], exc)
                return
            try:
                callback(k, msg)
            except Exception:  # a handler bug must not kill Zenoh's thread
                log.exception("handler for %s failed", k)

        self._handles.append(self.session.declare_subscriber(key, on_sample))

    def queryable(self, key: str, handler: Callable[[zenoh.Query], None]) -> None:
        """Declare a queryable; the handler replies with ``query.reply(...)``."""

        def on_query(query: zenoh.Query) -> None:
            try:
                handler(query)
            except Exception as exc:
                log.exception("queryable %s failed", key)
                query.reply_err(str(exc).encode())

        self._handles.append(self.session.declare_queryable(key, on_query))

    def announce(self, token_key: str) -> None:
        """Declare a liveliness token; it vanishes when the session closes."""
        self._handles.append(self.session.liveliness().declare_token(token_key))

    def alive(self, selector: str, timeout_s: float = 1.0) -> set[str]:
        """Keys of the liveliness tokens currently matching ``selector``."""
        found: set[str] = set()
        for reply in self.session.liveliness().get(selector, timeout=timeout_s):
            if reply.ok is not None:
                found.add(str(reply.ok.key_expr))
        return found

    def stats(self) -> dict[str, dict[str, int]]:
        return {"received": dict(self.received), "dropped": dict(self.dropped)}

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        for h in self._handles:
            try:
                h.undeclare()
            except Exception:  # already gone with the session
                log.debug("undeclare failed", exc_info=True)
        for pub in self._publishers.values():
            try:
                pub.undeclare()
            except Exception:
                log.debug("publisher undeclare failed", exc_info=True)
        self.session.close()

    def __enter__(self) -> Bus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
