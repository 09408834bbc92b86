"""``llmland-router``: a Zenoh router in Python (no ``zenohd`` is on the registries).

Listens on ``--listen``/``ZENOH_LISTEN`` (default ``tcp/127.0.0.1:7447``: loopback only; a
container sets ``tcp/0.0.0.0:7447`` or a ``tls/`` endpoint) and routes between peers, clients and
other routers (``--connect``/``ZENOH_CONNECT``) on several hosts. Stops on SIGTERM/SIGINT.

Secured bus (docs/network.md): ``ZENOH_TLS_ROOT_CA``, ``ZENOH_TLS_CERTIFICATE``,
``ZENOH_TLS_PRIVATE_KEY`` give the router its identity and mutual TLS on ``tls/`` endpoints (both
listening and connecting to another router); ``LLMLAND_ROUTER_ACL=true`` turns on access control
from :class:`RouterSettings` (:mod:`llmland_schemas.security`: ground station, drones, their
planners). ``--print-config`` prints the resulting Zenoh config and exits.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from typing import Annotated, Any

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

from .bus import DEFAULT_ENDPOINT, ZenohSettings, make_config, open_session
from .security import FleetPolicy, access_control
from .service import configure_logging, shutdown_event

log = logging.getLogger("llmland.router")


class RouterSettings(BaseSettings):
    """Access control of a router (``LLMLAND_ROUTER_*``); lists accept comma-separated strings."""

    model_config = SettingsConfigDict(env_prefix="LLMLAND_ROUTER_", extra="ignore")

    acl: bool = False
    #: certificate common names of the ground station (reasoner, mission CLI, displays)
    acl_ground: Annotated[list[str], NoDecode] = Field(default_factory=lambda: ["ground"])
    #: drone ids (= their certificates' common names); ``planner-<d>`` is each one's planner
    acl_drones: Annotated[list[str], NoDecode] = Field(default_factory=list)
    acl_planner_onboard: bool = False
    #: plain-TCP links count as the ground station: only when this router's TCP listener is loopback
    acl_trust_plain_tcp: bool = False

    @field_validator("acl_ground", "acl_drones", mode="before")
    @classmethod
    def _split(cls, value: Any) -> Any:
        if isinstance(value, str):
            return [v.strip() for v in value.split(",") if v.strip()]
        return value

    def policy(self) -> FleetPolicy:
        return FleetPolicy(ground=self.acl_ground, drones=self.acl_drones, planner_onboard=self.acl_planner_onboard,
                           trust_plain_tcp=self.acl_trust_plain_tcp)


def router_config(zenoh_settings: ZenohSettings, router: RouterSettings) -> Any:
    """The router's zenoh Config: bus settings (endpoints, TLS) plus access control when enabled."""
    conf = make_config(zenoh_settings)
    if router.acl:
        if any(e.startswith("tcp/") and not e.startswith(("tcp/127.", "tcp/localhost", "tcp/[::1]"))
               for e in zenoh_settings.listen) and router.acl_trust_plain_tcp:
            raise ValueError("LLMLAND_ROUTER_ACL_TRUST_PLAIN_TCP needs every tcp/ listener on loopback")
        conf.insert_json5("access_control", json.dumps(access_control(router.policy())))
    return conf


def _split(text: str | None) -> list[str] | None:
    return [c.strip() for c in text.split(",") if c.strip()] if text is not None else None


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--listen", help="comma-separated endpoints (overrides ZENOH_LISTEN)")
    parser.add_argument("--connect", help="comma-separated routers to peer with (overrides ZENOH_CONNECT)")
    parser.add_argument("--print-config", action="store_true", help="print the access-control config and exit")
    args = parser.parse_args(argv)
    configure_logging()
    settings = ZenohSettings()
    # A router listens; it connects only to other routers it is told about (never the client default).
    listen = _split(args.listen) or settings.listen or [DEFAULT_ENDPOINT]
    connect = _split(args.connect)
    if connect is None:
        connect = settings.connect if "connect" in settings.model_fields_set else []
    settings = settings.model_copy(update={"mode": "router", "listen": listen, "connect": connect})
    router = RouterSettings()
    conf = router_config(settings, router)
    if args.print_config:
        sys.stdout.write(conf.get_json("access_control") + "\n")  # the command's output
        return
    stop = shutdown_event()
    session = open_session(settings, conf)
    try:
        log.info("zenoh router %s listening on %s (TLS %s, ACL %s)", session.zid(), settings.listen,
                 "on" if settings.tls_root_ca else "off",
                 f"on: ground={router.acl_ground} drones={router.acl_drones}" if router.acl else "off")
        stop.wait()
    finally:
        session.close()


if __name__ == "__main__":
    main()
