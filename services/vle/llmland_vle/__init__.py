"""LLM-Land VLE service: captions camera frames and per-obstacle crops.

Importing the package sets ``OMP_WAIT_POLICY=PASSIVE`` (unless already set) before torch
starts its thread pool: on a small shared CPU, spinning OpenMP workers made batched
inference and training up to ~8x slower whenever another process was busy.
"""

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__version__ = "0.1.0"
