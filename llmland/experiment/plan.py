"""The paper's experiments (DESIGN §8) as lists of trials, and the paper's numbers to compare.

- ``exp1`` — open field, one pedestrian near the path, every method;
- ``exp2`` — the three worlds, every method;
- ``exp3`` — LLM backends side by side under ``llm-land``: the default model (measured
  latency), any GGUF given by path (measured), and the paper's four models replayed with
  ``fixed:`` latency models (their Exp. 3 latencies; the content still comes from the default
  model, only the timing is replayed).

Trial ``i`` of a row flies seed ``seed_base + i``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from llmland_schemas import METHOD_NAMES, WORLD_NAMES

from ..stacks import StackConfig

EXPERIMENTS = ("exp1", "exp2", "exp3")
#: the methods an experiment compares (every method but the sim's own reference controller)
ALL_METHODS: tuple[str, ...] = tuple(m for m in METHOD_NAMES if m != "reference")
ALL_WORLDS: tuple[str, ...] = WORLD_NAMES
#: the default model's row name in exp3
DEFAULT_LLM = "SmolLM2-135M-Instruct (measured)"

#: Paper, Table I (Exp. 1: 50 trials, open field, one moving person): success rate %.
PAPER_EXP1 = {"baseline": 34.0, "llm": 6.0, "llm-land": 96.0}
#: Paper, Table II (Exp. 2): success rate % per world.
PAPER_EXP2 = {
    "baseline": {"open_field": 34.0, "urban": 28.0, "forest_edge": 32.0},
    "llm": {"open_field": 8.0, "urban": 12.0, "forest_edge": 6.0},
    "llm-land": {"open_field": 94.0, "urban": 74.0, "forest_edge": 80.0},
}
#: Paper, Table III (Exp. 3, RTX 3070 Ti laptop GPU): (latency ms, peak VRAM GB, success %).
PAPER_EXP3 = {
    "Llama-3.2-1B-Instruct": (1453.6, 1.5, 94.0),
    "Qwen2.5-1.5B-R1-Distilled": (1510.2, 2.3, 70.0),
    "Qwen2.5-3B": (1889.5, 2.9, 82.0),
    "Llama-3.2-3B-Instruct": (2252.7, 2.9, 60.0),
}
PAPER_METHOD_NAMES = {"baseline": "Baseline MPC", "llm": "LLM–MPC", "llm-land": "LLM-Land",
                      "conservative": "not in the paper"}


@dataclass(frozen=True)
class Trial:
    """One episode of an experiment. ``variant`` names the exp3 LLM row ("" otherwise)."""

    world: str
    method: str
    seed: int
    variant: str = ""
    latency_model: str | None = None
    llm_model_path: str | None = None
    specs: str = "pipeline"
    n_pedestrians: int | None = None

    @property
    def key(self) -> tuple[str, str, str, int]:
        """Identity in ``trials.csv`` (``--resume`` skips keys already there)."""
        return (self.world, self.method, self.variant, self.seed)

    @property
    def name(self) -> str:
        v = f"-{self.variant}" if self.variant else ""
        return f"{self.world}-{self.method}{v}-s{self.seed}".replace(" ", "_").replace("/", "_")

    def stack(self) -> StackConfig:
        return StackConfig(method=self.method, specs=self.specs, llm_model_path=self.llm_model_path)  # type: ignore[arg-type]


def build_trials(experiment: str, *, trials: int, seed_base: int, methods: list[str] | None = None,
                 worlds: list[str] | None = None, latency_model: str | None = None, specs: str = "pipeline",
                 ggufs: list[Path] | None = None) -> list[Trial]:
    """Every trial of ``experiment`` (``--methods``/``--worlds`` narrow it down)."""
    seeds = [seed_base + i for i in range(trials)]
    if experiment == "exp1":
        return [Trial("open_field", m, s, latency_model=latency_model, specs=specs, n_pedestrians=1)
                for m in (methods or ALL_METHODS) for s in seeds]
    if experiment == "exp2":
        return [Trial(w, m, s, latency_model=latency_model, specs=specs)
                for w in (worlds or ALL_WORLDS) for m in (methods or ALL_METHODS) for s in seeds]
    if experiment == "exp3":
        rows: list[tuple[str, str | None, str | None]] = [(DEFAULT_LLM, None, latency_model)]
        rows += [(f"{p.stem} (measured)", str(p), latency_model) for p in (ggufs or [])]
        rows += [(f"{name} (latency replay)", None, f"fixed:{lat}") for name, (lat, _, _) in PAPER_EXP3.items()]
        return [Trial(w, "llm-land", s, variant=v, latency_model=lat, llm_model_path=path, n_pedestrians=1)
                for v, path, lat in rows for w in (worlds or ["open_field"]) for s in seeds]
    raise ValueError(f"unknown experiment {experiment!r}; choose from {', '.join(EXPERIMENTS)}")
