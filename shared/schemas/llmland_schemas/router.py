"""``llmland-router``: a Zenoh router in Python (no ``zenohd`` is on the registries).

Listens on ``ZENOH_LISTEN`` (default ``tcp/0.0.0.0:7447`` inside a container, set
``tcp/127.0.0.1:7447`` for loopback only) and routes between peers and clients on
several hosts. Stops on SIGTERM/SIGINT.
"""

from __future__ import annotations

import argparse
import logging
import os

from .bus import DEFAULT_ENDPOINT, ZenohSettings, open_session
from .service import configure_logging, shutdown_event

log = logging.getLogger("llmland.router")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--listen", help="comma-separated endpoints (overrides ZENOH_LISTEN)")
    parser.add_argument("--connect", help="comma-separated routers to peer with (overrides ZENOH_CONNECT)")
    args = parser.parse_args(argv)
    configure_logging()
    settings = ZenohSettings()
    # A router listens; it connects only to other routers it is told about.
    listen = args.listen.split(",") if args.listen else (settings.listen or [DEFAULT_ENDPOINT])
    connect = args.connect.split(",") if args.connect else os.environ.get("ZENOH_CONNECT", "").split(",")
    settings = settings.model_copy(
        update={"mode": "router", "listen": listen, "connect": [c for c in connect if c.strip()]}
    )
    stop = shutdown_event()
    session = open_session(settings)
    try:
        log.info("zenoh router %s listening on %s", session.zid(), settings.listen)
        stop.wait()
    finally:
        session.close()


if __name__ == "__main__":
    main()
