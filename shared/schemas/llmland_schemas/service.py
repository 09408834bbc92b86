"""Small pieces every service's ``main`` uses: logging set-up and clean shutdown."""

from __future__ import annotations

import logging
import os
import signal
import threading
import time
from typing import TypeVar

from pydantic import ValidationError
from pydantic_settings import BaseSettings


def configure_logging(level: str | None = None) -> None:
    """Log to stderr with timestamps; level from ``LLMLAND_LOG_LEVEL`` (default INFO)."""
    logging.basicConfig(
        level=(level or os.environ.get("LLMLAND_LOG_LEVEL", "INFO")).upper(),
        format="%(asctime)s %(levelname).1s %(name)s: %(message)s",
    )


#: The exit status of a service whose settings are invalid (a usage error, like argparse's).
BAD_SETTINGS_EXIT = 2

_S = TypeVar("_S", bound=BaseSettings)


def settings_or_exit(cls: type[_S]) -> _S:
    """``cls()`` (a service's pydantic-settings, read from its ``LLMLAND_<SERVICE>_*`` environment),
    or, when a value is invalid, one log line per bad field naming its variable, and exit
    :data:`BAD_SETTINGS_EXIT` (was a pydantic traceback from the service, then one from the CLI)."""
    try:
        return cls()
    except ValidationError as exc:
        prefix = str(cls.model_config.get("env_prefix", "")).upper()
        log = logging.getLogger(__name__)
        for err in exc.errors():
            field = ".".join(str(part) for part in err["loc"]) or "settings"
            log.error("bad setting %s%s: %s (got %r)", prefix, field.upper(), err["msg"], err.get("input"))
        raise SystemExit(BAD_SETTINGS_EXIT) from None


def shutdown_event() -> threading.Event:
    """An event set on SIGTERM or SIGINT, so the main loop can close the bus and exit."""
    stop = threading.Event()

    def _handler(signum: int, _frame: object) -> None:
        logging.getLogger(__name__).info("signal %d: shutting down", signum)
        stop.set()

    signal.signal(signal.SIGTERM, _handler)
    signal.signal(signal.SIGINT, _handler)
    return stop


#: set by ``llmland``'s launcher to its own pid in every service it starts
LAUNCHER_PID_ENV = "LLMLAND_LAUNCHER_PID"
#: seconds between two looks at whether the launcher is still this process's parent
LAUNCHER_POLL_S = 0.5


def watch_launcher(poll_s: float = LAUNCHER_POLL_S) -> threading.Thread | None:
    """Stop this service (SIGTERM to itself, so its own clean shutdown runs) once the ``llmland``
    process that launched it is gone, even if that one was SIGKILLed and could not stop it.

    Only where ``LLMLAND_LAUNCHER_PID`` names this process's parent (the launcher sets it): a
    service started by hand, by compose or by systemd is never tied to anyone. Returns the
    watching thread (a daemon), or ``None`` when there is nothing to watch."""
    launcher = os.environ.get(LAUNCHER_PID_ENV, "")
    if not launcher.isdigit() or int(launcher) != os.getppid():
        return None
    launcher_pid = int(launcher)

    def watch() -> None:
        while os.getppid() == launcher_pid:
            time.sleep(poll_s)
        logging.getLogger(__name__).warning("launcher %d is gone: shutting down", launcher_pid)
        os.kill(os.getpid(), signal.SIGTERM)

    thread = threading.Thread(target=watch, name="launcher-watch", daemon=True)
    thread.start()
    return thread
