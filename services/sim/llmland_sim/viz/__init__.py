"""Rerun recording of a landing (DESIGN §9): scene graph, cameras and perception, plots,
text log and the layout they open in. ``SimRecorder`` is the sim's one entry point."""

from .recorder import SimRecorder

__all__ = ["SimRecorder"]
