"""Array type aliases shared by every package (one definition each).

``FloatArray`` is a float64 numpy array of any shape (shapes and units are given where the
array is used); ``BoolArray`` a boolean mask; ``VecLike`` anything numpy can read as a
vector (a list, a tuple or an array).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
VecLike = Sequence[float] | NDArray[Any]

__all__ = ["BoolArray", "FloatArray", "VecLike"]
