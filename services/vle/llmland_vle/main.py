"""``llmland-vle``: the VLE service, and the commands that make and measure its model.

* ``llmland-vle`` or ``llmland-vle serve`` — the service: camera frames in, scene descriptions
  out, the caption queryable (settings from ``LLMLAND_VLE_*``, bus from ``ZENOH_*``);
  SIGTERM / Ctrl-C stop it cleanly.
* ``llmland-vle train [...]`` — regenerate simcap's data from seeds, train, evaluate on
  held-out seeds, write the weights and model card (``llmland-vle train --help``).
* ``llmland-vle bench [--quick]`` — latency and drop figures as one JSON object.

``train`` and ``bench`` render with the simulator (the ``train`` extra) through
:mod:`llmland_vle.simrender`; ``serve`` never imports it.
"""

from __future__ import annotations

import argparse
import logging
import sys

from llmland_schemas.bus import Bus
from llmland_schemas.service import configure_logging, settings_or_exit, shutdown_event, watch_launcher

from . import bench
from .training import cli as training_cli

log = logging.getLogger("llmland.vle")

#: seconds between statistics lines in the service log
STATS_PERIOD_S = 30.0


def serve(_args: argparse.Namespace | None = None) -> int:
    """Run the service until SIGTERM / Ctrl-C, logging its statistics every :data:`STATS_PERIOD_S`."""
    from .service import VleService
    from .settings import VleSettings

    configure_logging()
    watch_launcher()
    settings = settings_or_exit(VleSettings)
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


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="llmland-vle", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.set_defaults(run=serve)
    sub = ap.add_subparsers(title="commands", metavar="{serve,train,bench}")
    sub.add_parser("serve", help="run the service (the default)").set_defaults(run=serve)
    train = sub.add_parser("train", help="train simcap from seeded renders", description=training_cli.__doc__)
    training_cli.add_arguments(train)
    train.set_defaults(run=training_cli.run)
    bench_p = sub.add_parser("bench", help="latency and drop figures (JSON)", description=bench.__doc__)
    bench.add_arguments(bench_p)
    bench_p.set_defaults(run=bench.run)
    return ap


def main(argv: list[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else 2
    code: int = args.run(args)
    return code


if __name__ == "__main__":
    sys.exit(main())
