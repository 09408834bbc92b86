"""Open Zenoh sessions from settings and exchange typed messages over them.

Settings come from the environment (``ZENOH_MODE``, ``ZENOH_CONNECT``, ``ZENOH_LISTEN``,
``ZENOH_CONFIG``, ``ZENOH_TLS_*``). The default is peer mode on loopback with explicit endpoints
and multicast scouting off: a process connects to ``tcp/127.0.0.1:7447`` (the endpoint the
``llmland`` CLI or ``llmland-router`` listens on), a peer listens on ``tcp/127.0.0.1:0`` only (so it
advertises only loopback locators to other peers: Zenoh's own peer default is ``tcp/[::]:0``) and
nothing is sent off the machine. ``ZENOH_TLS_ROOT_CA``/``_CERTIFICATE``/``_PRIVATE_KEY`` set up
(mutual) TLS for ``tls/...`` endpoints (docs/network.md).

:class:`Bus` wraps a session: typed publishers, subscribers that validate every payload
and count and drop malformed ones (the service stays up), and ``close()`` that always
runs (a callback subscriber left open hangs process exit).

Encoding policy: every JSON message says ``application/json`` (puts and query replies, also
when a queryable handler forgets to say so), camera frames say ``application/octet-stream``, error
replies ``text/plain``. JSON subscribers drop samples that announce a non-JSON encoding (a frame
on a message key); the untyped default (``zenoh/bytes``, what ``z_put`` sends) is accepted.
"""

from __future__ import annotations

import json
import logging
import threading
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar, cast

import zenoh
from pydantic import BaseModel, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

from .codec import MessageError, decode, encode
from .security import tls_config

log = logging.getLogger(__name__)
M = TypeVar("M", bound=BaseModel)
T = TypeVar("T")

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
#: where a peer listens unless told otherwise: loopback, a port the OS picks
LOOPBACK_LISTEN = "tcp/127.0.0.1:0"
JSON = zenoh.Encoding.APPLICATION_JSON
BINARY = zenoh.Encoding.APPLICATION_OCTET_STREAM
TEXT = zenoh.Encoding.TEXT_PLAIN
#: encodings a JSON subscriber accepts (the untyped/text ones: hand-written tools rarely set one)
JSON_COMPATIBLE = frozenset({"application/json", "text/json", "zenoh/bytes", "zenoh/string", "text/plain"})


def encoding_name(encoding: zenoh.Encoding | None) -> str:
    """The MIME part of an encoding (``application/json`` for ``application/json;schema``)."""
    return str(encoding if encoding is not None else zenoh.Encoding.ZENOH_BYTES).split(";", 1)[0]


def is_json(encoding: zenoh.Encoding | None) -> bool:
    """Whether a sample's encoding may carry a JSON message (see the encoding policy above)."""
    return encoding_name(encoding) in JSON_COMPATIBLE


class ZenohSettings(BaseSettings):
    """How a process joins the bus. Lists accept comma-separated strings."""

    model_config = SettingsConfigDict(env_prefix="ZENOH_", extra="ignore")

    mode: Literal["peer", "client", "router"] = "peer"
    connect: Annotated[list[str], NoDecode] = [DEFAULT_ENDPOINT]
    listen: Annotated[list[str], NoDecode] = []
    config: Path | None = None
    multicast_scouting: bool = False
    #: CA that signs every certificate of the fleet (enables ``tls/`` endpoints)
    tls_root_ca: Path | None = None
    #: this process's certificate and key (its identity: the common name the router's ACL matches)
    tls_certificate: Path | None = None
    tls_private_key: Path | None = None
    #: mutual TLS: a listener demands a certificate, a connecting side shows its own
    tls_mtls: bool = True

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
    elif settings.mode == "peer" and settings.config is None:
        conf.insert_json5("listen/endpoints", json.dumps([LOOPBACK_LISTEN]))
    if settings.tls_root_ca is not None:
        block = tls_config(settings.tls_root_ca, settings.tls_certificate, settings.tls_private_key,
                           mtls=settings.tls_mtls and settings.tls_certificate is not None)
        conf.insert_json5("transport/link/tls", json.dumps(block))
    elif settings.tls_certificate is not None:
        raise ValueError("ZENOH_TLS_CERTIFICATE needs ZENOH_TLS_ROOT_CA (the CA that signed the fleet's certificates)")
    return conf


def open_session(settings: ZenohSettings | None = None, config: zenoh.Config | None = None) -> zenoh.Session:
    """Open a Zenoh session from settings (environment when ``None``) or a ready ``config``."""
    settings = settings or ZenohSettings()
    zenoh.init_log_from_env_or("error")
    log.debug("opening zenoh session mode=%s connect=%s listen=%s", settings.mode, settings.connect, settings.listen)
    return zenoh.open(config if config is not None else make_config(settings))


class JsonReplies:
    """A query whose replies default to ``application/json`` (errors to ``text/plain``): the encoding
    policy holds for every queryable, whatever its handler passes."""

    def __init__(self, query: zenoh.Query) -> None:
        self._query = query

    def reply(self, key_expr: Any, payload: Any, *, encoding: Any = None, **kwargs: Any) -> None:
        self._query.reply(key_expr, payload, encoding=encoding or JSON, **kwargs)

    def reply_err(self, payload: Any, *, encoding: Any = None) -> None:
        self._query.reply_err(payload, encoding=encoding or TEXT)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._query, name)


class Bus:
    """A Zenoh session with typed, validating publish/subscribe helpers.

    Use as a context manager or call :meth:`close`. Subscriber callbacks run on Zenoh's
    threads; keep them short (hand work to a queue).
    """

    def __init__(self, settings: ZenohSettings | None = None, session: zenoh.Session | None = None) -> None:
        self.session = session if session is not None else open_session(settings)
        self._publishers: dict[tuple[str, bool], zenoh.Publisher] = {}
        self._handles: list[Any] = []
        self._lock = threading.Lock()
        self.received: Counter[str] = Counter()
        self.dropped: Counter[str] = Counter()
        self._closed = False

    # ------------------------------------------------------------------ publish
    def publisher(self, key: str, *, express: bool = False, encoding: zenoh.Encoding | None = None,
                  block: bool = True) -> zenoh.Publisher:
        """The publisher for ``key``, declared on first use (JSON unless told otherwise; each put still
        names its encoding, so a key used for both kinds stays truthful).

        ``block``: when the transmission queue is full, wait (``CongestionControl.BLOCK``) instead of
        dropping the sample (Zenoh's default for puts, ``DROP``)."""
        congestion = zenoh.CongestionControl.BLOCK if block else zenoh.CongestionControl.DROP
        with self._lock:
            pub = self._publishers.get((key, block))
            if pub is None:
                pub = self.session.declare_publisher(
                    key, encoding=encoding or zenoh.Encoding.APPLICATION_JSON, express=express,
                    congestion_control=congestion,
                )
                self._publishers[(key, block)] = pub
            return pub

    def publish(self, key: str, msg: BaseModel, *, express: bool = False) -> None:
        """Publish a message as JSON on ``key`` (``express``: never batched, for control-loop
        messages whose latency matters more than throughput). Never dropped under congestion:
        messages are small and each one counts (a lost command or spec stalls a lockstep episode
        until a timeout and makes a seeded run differ)."""
        self.publisher(key, express=express).put(encode(msg), encoding=JSON)

    def publish_bytes(self, key: str, payload: bytes, *, encoding: zenoh.Encoding | None = None,
                      block: bool = False) -> None:
        """Publish raw bytes (camera frames: ``application/octet-stream`` unless told otherwise).

        ``block``: never drop it under congestion (lockstep frames: the sim waits for the answer to
        a perceived frame, and the planner for the frame its state names); by default a frame
        that finds the queue full is dropped, as a live camera's would be."""
        enc = encoding or BINARY
        self.publisher(key, encoding=enc, block=block).put(payload, encoding=enc)

    # ------------------------------------------------------------------ subscribe
    def subscribe(self, key: str, model: type[M], callback: Callable[[str, M], None]) -> None:
        """Subscribe with validation: ``callback(key, msg)`` gets only valid messages."""

        def parse(payload: bytes) -> M:
            return decode(model, payload)

        self.subscribe_parsed(key, parse, callback, accept=is_json)

    def subscribe_parsed(
        self, key: str, parse: Callable[[bytes], T], callback: Callable[[str, T], None],
        accept: Callable[[zenoh.Encoding], bool] | None = None,
    ) -> None:
        """Subscribe with a custom parser; parse errors (and encodings ``accept`` refuses) are logged,
        counted and dropped."""

        def on_sample(sample: zenoh.Sample) -> None:
            k = str(sample.key_expr)
            self.received[k] += 1
            try:
                if accept is not None and not accept(sample.encoding):
                    raise MessageError(f"unexpected encoding {encoding_name(sample.encoding)}")
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
        """Declare a queryable; the handler replies with ``query.reply(...)`` (JSON unless it names
        another encoding, :class:`JsonReplies`)."""

        def on_query(query: zenoh.Query) -> None:
            try:
                handler(cast(zenoh.Query, JsonReplies(query)))
            except Exception as exc:
                log.exception("queryable %s failed", key)
                query.reply_err(str(exc).encode(), encoding=TEXT)
                query.drop()  # final now: the logged traceback keeps the query alive and would stall the asker

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
