"""``python -m llmland_schemas.health SERVICE [DRONE]``: exit 0 if the service is alive on the bus.

Used by compose health checks: it joins the bus with the container's ZENOH_* settings and
looks for the service's liveliness token ``llmland/<drone>/alive/<service>`` (a shared service
such as the reasoner: ``llmland/@ground/alive/<service>``).
"""

from __future__ import annotations

import sys

from .bus import Bus
from .keys import alive_selector


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if not args:
        sys.stderr.write("usage: python -m llmland_schemas.health SERVICE [DRONE|*]\n")
        return 2
    service, drone = args[0], (args[1] if len(args) > 1 else "*")
    with Bus() as bus:
        found = bus.alive(alive_selector(service, drone), timeout_s=2.0)
    return 0 if found else 1


if __name__ == "__main__":
    sys.exit(main())
