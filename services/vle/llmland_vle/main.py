"""``llmland-vle``: run the VLE service, or ``llmland-vle train`` / ``llmland-vle bench``.

* ``llmland-vle`` — the service (settings from ``LLMLAND_VLE_*``, bus from ``ZENOH_*``);
  SIGTERM / Ctrl-C stop it cleanly.
* ``llmland-vle train [...]`` — regenerate simcap's data from seeds, train, evaluate on
  held-out seeds, write the weights and model card (``llmland-vle train --help``).
* ``llmland-vle bench [--quick]`` — latency and drop figures as one JSON object.
"""

from __future__ import annotations

import logging
import sys

from llmland_schemas.bus import Bus
from llmland_schemas.service import configure_logging, shutdown_event

log = logging.getLogger("llmland.vle")

#: seconds between statistics lines in the service log
STATS_PERIOD_S = 30.0


def serve() -> int:
    from .service import VleService
    from .settings import VleSettings

    configure_logging()
    settings = VleSettings()
    stop = shutdown_event()
    with Bus() as bus:
        service = VleService(settings, bus)
        try:
            while not stop.wait(STATS_PERIOD_S):
                log.info("stats %s", service.stats())
        finally:
            service.close()
            log.info("vle stopped: %s", service.stats())
    return 0


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    if args and args[0] == "train":
        from .training.cli import main as train_main

        return train_main(args[1:])
    if args and args[0] == "bench":
        from .bench import main as bench_main

        return bench_main(args[1:])
    if args and args[0] in ("-h", "--help"):
        sys.stdout.write(__doc__ or "")
        return 0
    if args:
        sys.stderr.write(f"unknown arguments {args}; try llmland-vle --help\n")
        return 2
    return serve()


if __name__ == "__main__":
    sys.exit(main())
