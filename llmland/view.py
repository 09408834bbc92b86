"""``llmland view FILE.rrd``: a recording in the local Rerun viewer, or, with no display,
served on loopback for a browser (the web viewer that comes with rerun-sdk)."""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import subprocess
import sys
from pathlib import Path

log = logging.getLogger("llmland.view")

LOOPBACK = "127.0.0.1"
#: the web viewer's HTTP port (rerun's default); its gRPC server takes GRPC_PORT
WEB_PORT = 9090
GRPC_PORT = 9876


def rerun_cli() -> str | None:
    """The ``rerun`` executable installed with this Python's rerun-sdk, else the one on PATH."""
    beside = Path(sys.executable).parent / "rerun"
    return str(beside) if beside.exists() else shutil.which("rerun")


def has_display(env: dict[str, str] | None = None) -> bool:
    """A graphical session to open a native window in (X11 or Wayland; macOS and Windows always)."""
    env = dict(os.environ) if env is None else env
    return sys.platform in ("darwin", "win32") or bool(env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"))


def viewer_command(cli: str, rrd: Path, *, web: bool, web_port: int = WEB_PORT, grpc_port: int = GRPC_PORT,
                   ) -> list[str]:
    """The ``rerun`` command line: the native viewer, or the web viewer served on loopback."""
    if not web:
        return [cli, str(rrd)]
    return [cli, "--serve-web", "--bind", LOOPBACK, "--web-viewer-port", str(web_port), "--port", str(grpc_port),
            str(rrd)]


def web_url(web_port: int = WEB_PORT, grpc_port: int = GRPC_PORT) -> str:
    """The address to open in a browser for a recording served by ``viewer_command(web=True)``."""
    return f"http://{LOOPBACK}:{web_port}/?url=rerun%2Bhttp://{LOOPBACK}:{grpc_port}/proxy"


#: The first bytes of a Rerun recording (``.rrd``) as rerun-sdk 0.2x writes it.
RRD_MAGIC = b"RRF2"


def cmd_view(args: argparse.Namespace) -> int:
    rrd = Path(args.file)
    if not rrd.is_file():
        log.error("no such recording: %s", rrd)
        return 2
    with rrd.open("rb") as fh:
        if fh.read(len(RRD_MAGIC)) != RRD_MAGIC:  # the viewer would serve nothing, silently, until killed
            log.error("%s is no Rerun recording (an .rrd file starts with %r)", rrd, RRD_MAGIC.decode())
            return 2
    cli = rerun_cli()
    if cli is None:
        log.error("the rerun viewer is not installed (pip install rerun-sdk)")
        return 2
    web = args.web or not has_display()
    cmd = viewer_command(cli, rrd, web=web, web_port=args.web_port, grpc_port=args.grpc_port)
    if web:
        log.info("serving %s on loopback: open %s (Ctrl-C stops)", rrd, web_url(args.web_port, args.grpc_port))
    try:
        return subprocess.run(cmd, check=False).returncode
    except KeyboardInterrupt:
        return 0


def add_view_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    view = sub.add_parser("view", help="open a Rerun recording (native viewer, or a web viewer on loopback)")
    view.add_argument("file", help="an .rrd recording, e.g. one written by `llmland land --rrd`")
    view.add_argument("--web", action="store_true", help="serve the web viewer even when there is a display")
    view.add_argument("--web-port", type=int, default=WEB_PORT, help="HTTP port of the web viewer")
    view.add_argument("--grpc-port", type=int, default=GRPC_PORT, help="port the recording is served from")
    view.set_defaults(func=cmd_view)
