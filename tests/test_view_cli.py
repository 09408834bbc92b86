"""`llmland view FILE.rrd`: native viewer with a display, the web viewer on loopback without."""

from __future__ import annotations

import os
import signal
import subprocess
import time
import urllib.request
from pathlib import Path

import pytest
import rerun as rr

from llmland.launch import free_port
from llmland.view import LOOPBACK, RRD_MAGIC, has_display, rerun_cli, viewer_command, web_url

from .conftest import run_cli

#: the web viewer answers within this long of starting (s)
SERVE_TIMEOUT_S = 30.0


def test_display_decides_native_or_web() -> None:
    assert has_display({"DISPLAY": ":0"}) or has_display({})  # macOS/Windows always have one
    assert viewer_command("rerun", Path("a.rrd"), web=False) == ["rerun", "a.rrd"]
    web = viewer_command("rerun", Path("a.rrd"), web=True, web_port=9100, grpc_port=9200)
    assert web[-1] == "a.rrd" and "--serve-web" in web and web[web.index("--bind") + 1] == LOOPBACK
    assert web_url(9100, 9200) == "http://127.0.0.1:9100/?url=rerun%2Bhttp://127.0.0.1:9200/proxy"


def test_missing_file_is_an_error(tmp_path: Path) -> None:
    proc = run_cli("view", str(tmp_path / "none.rrd"))
    assert proc.returncode == 2 and "no such recording" in proc.stderr


def test_a_file_that_is_no_recording_is_an_error(tmp_path: Path) -> None:
    """Was: the web viewer started on a PNG and served nothing until killed."""
    png = tmp_path / "frame.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    proc = run_cli("view", str(png))
    assert proc.returncode == 2 and "no Rerun recording" in proc.stderr


def test_web_viewer_serves_a_recording_on_loopback(tmp_path: Path) -> None:
    cli = rerun_cli()
    if cli is None:
        pytest.skip("rerun CLI not installed")
    rrd = tmp_path / "tiny.rrd"
    rec = rr.RecordingStream("llmland-view-test")
    rec.save(str(rrd))
    rec.log("plot/x", rr.Scalars(1.0))
    rec.flush()
    rec.disconnect()
    assert rrd.read_bytes()[: len(RRD_MAGIC)] == RRD_MAGIC  # what `llmland view` checks a file by
    web_port, grpc_port = free_port(), free_port()
    proc = subprocess.Popen(viewer_command(cli, rrd, web=True, web_port=web_port, grpc_port=grpc_port),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + SERVE_TIMEOUT_S
        while True:
            try:
                with urllib.request.urlopen(f"http://{LOOPBACK}:{web_port}/", timeout=2.0) as page:
                    assert page.status == 200 and b"rerun" in page.read().lower()
                    break
            except OSError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise
                time.sleep(0.3)
    finally:  # the `rerun` script runs the viewer binary as its child: stop the whole group
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=10)
