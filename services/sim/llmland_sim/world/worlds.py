"""Seeded worlds for the pybullet simulator: ``open_field``, ``urban`` and ``forest_edge``.

``build_world(client, name, seed)`` creates the ground, the landing pad at the target, the
static obstacles and the moving actors (pedestrians, cars) in a pybullet client and returns
a :class:`~.model.World`. Everything is drawn from generators derived from ``seed``: the same
seed gives the same object list, positions, colours and actor trajectories; different seeds
give different worlds.

Frames and units per ``docs/conventions.md``: world ENU, metres, radians. The ground is
``z = 0`` except in ``forest_edge`` (gentle heightfield terrain; query
:meth:`~.model.World.ground_height`). ``target_m`` is the ground point at the pad centre;
``start_m`` the drone start (2.5–4 m above the ground, 8–10 m away horizontally).

Where each part lives: footprints in :mod:`.geometry`, terrain in :mod:`.terrain`, the world
model in :mod:`.model`, the placement guarantees in :mod:`.layout` (checked by the tests), the
builder in :mod:`.builder`, one recipe per world in :mod:`.recipes`, bodies in :mod:`.shapes`.
"""

from __future__ import annotations

import logging

from llmland_schemas import WORLD_NAMES

from .builder import WorldBuilder
from .model import World
from .recipes import RECIPES

logger = logging.getLogger(__name__)


def build_world(
    client: int,
    name: str,
    seed: int,
    *,
    n_pedestrians: int | None = None,
    renderer: str = "auto",
) -> World:
    """Create world ``name`` (one of :data:`WORLD_NAMES`) from ``seed`` in pybullet ``client``.

    The world creates its own ground; call it on an empty client (e.g. right after
    ``p.connect`` or ``p.resetSimulation``).

    Args:
        client: pybullet physics client id.
        name: ``"open_field"``, ``"urban"`` or ``"forest_edge"``.
        seed: world seed (any int; the same seed gives the same world).
        n_pedestrians: override the world's default number of pedestrians
            (open_field 1, urban 2–3, forest_edge 1–2); the rest of the layout is unchanged.
        renderer: ``"auto"`` / ``"egl"`` first load pybullet's EGL renderer plugin into the
            client when available (it only sees bodies created after it is loaded, see
            :func:`llmland_sim.renderer.prepare_renderer`); ``"tiny"`` skips that.
    """
    if name not in RECIPES:
        raise ValueError(f"unknown world {name!r}; expected one of {WORLD_NAMES}")
    if renderer != "tiny":
        from llmland_sim.renderer import prepare_renderer

        prepare_renderer(client, renderer)
    world = RECIPES[name](WorldBuilder(client, name, seed), n_pedestrians)
    logger.info("built world %s", world.summary())
    return world
