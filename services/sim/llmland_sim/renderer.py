"""Which pybullet renderer a camera uses, and the EGL plugin's life cycle per client.

Renderers:

* ``"tiny"``: pybullet's CPU TinyRenderer (≈ 40 ms at 384×384); float32 depth buffer.
* ``"egl"``: pybullet's EGL plugin with ``ER_BULLET_HARDWARE_OPENGL`` (≈ 12 ms on Mesa
  llvmpipe, faster on a GPU). The plugin only renders bodies created **after** it was loaded
  into the client, so call :func:`prepare_renderer` right after ``p.connect`` (``build_world``
  does it for you). With Mesa the depth buffer has 16 bits: depth is quantised to
  ≈ ``z² · 1.5e-5 / near`` (1.5 cm at 10 m, 6 cm at 20 m with ``near = 0.1``). Once the
  plugin is loaded, pybullet serves ``"tiny"`` requests of that client with EGL as well.
* ``"auto"``: EGL when it works on this machine (probed once per process in a subprocess,
  because a broken EGL setup makes the plugin call ``exit()``), else tiny.
"""

from __future__ import annotations

import ctypes
import importlib.util
import logging
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pybullet as p

logger = logging.getLogger(__name__)

_EGL_PLUGIN_BY_CLIENT: dict[int, int] = {}
_EGL_PROBE: tuple[bool, str] | None = None

_PROBE_SCRIPT = r"""
import importlib.util, sys
import numpy as np
import numpy as np
import pybullet as p
c = p.connect(p.DIRECT)
spec = importlib.util.find_spec("eglRenderer")
if spec is None or spec.origin is None:
    sys.exit(3)
if p.loadPlugin(spec.origin, "_eglRendererPlugin", physicsClientId=c) < 0:
    sys.exit(4)
v = p.createVisualShape(p.GEOM_BOX, halfExtents=[1, 1, 1], physicsClientId=c)
b = p.createMultiBody(0, -1, v, [3, 0, 0], physicsClientId=c)
view = p.computeViewMatrix([0, 0, 0], [1, 0, 0], [0, 0, 1])
proj = p.computeProjectionMatrixFOV(60, 1, 0.1, 10)
img = p.getCameraImage(16, 16, view, proj, renderer=p.ER_BULLET_HARDWARE_OPENGL, physicsClientId=c)
seg = np.asarray(img[4]).reshape(16, 16)
sys.stdout.write("\nLLMLAND_EGL_OK\n" if (seg == b).any() else "\nLLMLAND_EGL_EMPTY\n")
sys.stdout.flush()
"""


def _egl_plugin_path() -> str | None:
    spec = importlib.util.find_spec("eglRenderer")
    return None if spec is None else spec.origin


def egl_available(timeout_s: float = 60.0) -> bool:
    """True when pybullet's EGL renderer works here (probed once per process, in a subprocess).

    The probe loads the plugin in a fresh interpreter and renders a box; a machine without
    libEGL (or without a usable display device) fails there instead of killing this process.
    """
    global _EGL_PROBE
    if _EGL_PROBE is None:
        if _egl_plugin_path() is None:
            _EGL_PROBE = (False, "eglRenderer module not found")
        else:
            try:
                res = subprocess.run(
                    [sys.executable, "-c", _PROBE_SCRIPT],
                    capture_output=True,
                    text=True,
                    timeout=timeout_s,
                    check=False,
                )
                ok = res.returncode == 0 and "LLMLAND_EGL_OK" in res.stdout
                gl = [ln.split("=", 1)[1] for ln in res.stdout.splitlines() if ln.startswith("GL_RENDERER=")]
                info = gl[0] if gl else f"rc={res.returncode}"
                _EGL_PROBE = (ok, info)
            except (OSError, subprocess.SubprocessError) as exc:
                _EGL_PROBE = (False, f"probe failed: {exc}")
        logger.info("EGL renderer available: %s (%s)", _EGL_PROBE[0], _EGL_PROBE[1])
    return _EGL_PROBE[0]


def egl_info() -> str:
    """GL renderer string found by the EGL probe (e.g. ``llvmpipe (...)``), or why it failed."""
    egl_available()
    assert _EGL_PROBE is not None
    return _EGL_PROBE[1]


@contextmanager
def _quiet_c_stdout() -> Iterator[None]:
    """Silence C-level writes to fd 1 (the EGL plugin prints its GL info there)."""
    try:
        sys.stdout.flush()
    except (AttributeError, OSError, ValueError):
        pass
    fd = 1  # C code writes to fd 1 whatever Python's sys.stdout is
    libc = None
    try:
        libc = ctypes.CDLL(None)
        saved = os.dup(fd)
    except OSError:  # no libc handle or no fd 1: nothing to silence
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, fd)
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved, fd)
        os.close(saved)
        os.close(devnull)


def egl_active(client: int) -> bool:
    """True when the EGL plugin renders for ``client`` (its clear colour differs from tiny's white).

    Renders a 2×2 image looking up into empty sky (≈ 0.1 ms without the plugin).
    """
    view = p.computeViewMatrix([0, 0, 1e4], [0, 0, 2e4], [1, 0, 0])
    proj = p.computeProjectionMatrixFOV(10, 1, 0.1, 1.0)
    img = p.getCameraImage(
        2,
        2,
        view,
        proj,
        renderer=p.ER_BULLET_HARDWARE_OPENGL,
        flags=p.ER_NO_SEGMENTATION_MASK,
        physicsClientId=client,
    )
    px = np.asarray(img[2], dtype=np.uint8).reshape(-1, 4)[0, :3]
    return bool(np.any(px != 255))


def prepare_renderer(client: int, renderer: str = "auto") -> str:
    """Make ``renderer`` usable in pybullet ``client``; returns the effective renderer.

    ``"tiny"`` → ``"tiny"``. ``"auto"`` / ``"egl"`` load the EGL plugin into the client
    (once; it must happen before any body is created) and return ``"egl"``; ``"auto"``
    falls back to ``"tiny"`` when EGL is unavailable or bodies already exist, ``"egl"`` raises
    ``RuntimeError`` instead. A GUI client renders with its own OpenGL context: ``"opengl"``.
    The environment variable ``LLMLAND_RENDERER=tiny|egl`` overrides ``"auto"``.
    """
    if renderer not in ("auto", "tiny", "egl"):
        raise ValueError(f"renderer must be 'auto', 'tiny' or 'egl', got {renderer!r}")
    if renderer == "auto":
        env = os.environ.get("LLMLAND_RENDERER", "").strip().lower()
        if env in ("tiny", "egl"):
            renderer = env
    if renderer == "tiny":
        return "tiny"
    info = p.getConnectionInfo(physicsClientId=client)
    if info.get("connectionMethod") == p.GUI:
        return "opengl"
    if egl_active(client):  # loaded earlier (by us or by the caller)
        return "egl"
    _EGL_PLUGIN_BY_CLIENT.pop(client, None)  # stale entry of a disconnected client with this id
    n_bodies = p.getNumBodies(physicsClientId=client)
    reason = ""
    if n_bodies > 0:
        reason = f"client {client} already has {n_bodies} bodies (load EGL before creating any)"
    elif not egl_available():
        reason = f"EGL unavailable: {egl_info()}"
    else:
        path = _egl_plugin_path()
        assert path is not None
        with _quiet_c_stdout():  # the plugin prints GL info on load and first render
            plugin = int(p.loadPlugin(path, "_eglRendererPlugin", physicsClientId=client))
            active = plugin >= 0 and egl_active(client)
        if active:
            _EGL_PLUGIN_BY_CLIENT[client] = plugin
            logger.info("EGL renderer plugin loaded into client %d (%s)", client, egl_info())
            return "egl"
        reason = "loadPlugin failed"
    if renderer == "egl":
        raise RuntimeError(f"EGL renderer requested but not usable: {reason}")
    logger.info("camera renderer: tiny (%s)", reason)
    return "tiny"


def release_renderer(client: int) -> None:
    """Forget (and unload) the EGL plugin of ``client``; call before disconnecting it."""
    plugin = _EGL_PLUGIN_BY_CLIENT.pop(client, None)
    if plugin is not None and p.isConnected(physicsClientId=client):
        p.unloadPlugin(plugin, physicsClientId=client)
