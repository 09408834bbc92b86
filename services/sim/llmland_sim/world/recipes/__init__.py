"""One recipe per world: ``build(builder, n_pedestrians) -> World``, dimensions as named constants."""

from collections.abc import Callable

from ..builder import WorldBuilder
from ..model import World
from . import forest_edge, open_field, urban

Recipe = Callable[[WorldBuilder, int | None], World]

#: The recipe of each world name.
RECIPES: dict[str, Recipe] = {
    "open_field": open_field.build,
    "urban": urban.build,
    "forest_edge": forest_edge.build,
}

__all__ = ["RECIPES", "Recipe"]
