"""``llmland-reasoner``: the ground-station reasoner (bus service + HTTP API in one process).

Loads the KB, the retriever and the LLM once, serves ``reasoner/spec`` on the bus for every
drone and the HTTP API on ``LLMLAND_REASONER_HTTP_HOST:PORT`` (127.0.0.1:8080 by default).
"""

from __future__ import annotations

import logging

import uvicorn
from llmland_schemas.bus import Bus
from llmland_schemas.keys import ground_alive
from llmland_schemas.service import configure_logging, settings_or_exit, watch_launcher

from .bus_service import ReasonerBusService, caption_via_vle
from .engine import ReasonerEngine
from .http_api import create_app
from .settings import ReasonerSettings

log = logging.getLogger("llmland.reasoner")


def main() -> None:
    configure_logging()
    watch_launcher()
    settings = settings_or_exit(ReasonerSettings)
    old_copy = settings.index_dir / "knowledge_base.json"  # where API writes went before kb_additions.json
    if settings.kb_path is None and old_copy.exists():
        log.warning("%s (a whole KB saved by an older version's API writes) is no longer loaded: it hid "
                    "newer shipped KBs; re-add its entries through the API or set LLMLAND_REASONER_KB_PATH",
                    old_copy)
    if settings.http_host not in ("127.0.0.1", "localhost", "::1") and settings.api_token is None:
        log.warning("HTTP API bound to %s without LLMLAND_REASONER_API_TOKEN", settings.http_host)
    engine = ReasonerEngine(settings)
    engine.extractor().warm_up()
    with Bus() as bus:
        service = ReasonerBusService(engine, bus)
        bus.announce(ground_alive("reasoner"))
        app = create_app(engine, caption_via_vle(bus), settings)
        log.info("reasoner ready: mode=%s models=%s http://%s:%d", settings.mode, engine.models(),
                 settings.http_host, settings.http_port)
        try:
            uvicorn.run(app, host=settings.http_host, port=settings.http_port, log_level="warning")
        finally:
            service.close()
            engine.close()


if __name__ == "__main__":
    main()
