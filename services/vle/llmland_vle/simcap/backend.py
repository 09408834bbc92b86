"""The ``simcap`` captioner backend: loads the committed weights and captions batches greedily.

A weights directory holds ``simcap.pt`` (a ``state_dict`` saved with ``torch.save``; loaded
with ``weights_only=True``, so no pickled classes) and ``simcap.json`` (model
configuration, vocabulary, version).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from ..captioner import BatchCaptioner, CaptionKind
from ..crops import check_rgb, resize
from .model import ModelConfig, SimCapNet, images_to_tensor
from .vocab import Vocab

log = logging.getLogger(__name__)

DEFAULT_WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
WEIGHTS_FILE = "simcap.pt"
META_FILE = "simcap.json"


def save_model(
    model: SimCapNet, vocab: Vocab, out_dir: Path, version: str, extra: dict[str, Any] | None = None
) -> None:
    """Write ``simcap.pt`` and ``simcap.json`` into ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    state = {k: v.detach().clone() for k, v in model.state_dict().items()}
    torch.save(state, out_dir / WEIGHTS_FILE)
    meta = {"version": version, "config": model.cfg.to_dict(), "vocab": vocab.itos, **(extra or {})}
    (out_dir / META_FILE).write_text(json.dumps(meta, indent=1) + "\n")


def bias_vector(vocab: Vocab, bias: dict[str, float] | None) -> torch.Tensor | None:
    """(V,) logit bias from ``{word: bias}`` (None if empty)."""
    if not bias:
        return None
    vec = torch.zeros(len(vocab))
    for word, b in bias.items():
        if word in vocab.stoi:
            vec[vocab.stoi[word]] = float(b)
    return vec


def load_meta(weights_dir: Path | None = None) -> dict[str, Any]:
    d = Path(weights_dir) if weights_dir is not None else DEFAULT_WEIGHTS_DIR
    meta: dict[str, Any] = json.loads((d / META_FILE).read_text())
    return meta


def load_model(weights_dir: Path | None = None) -> tuple[SimCapNet, Vocab, str]:
    """Model (eval mode), vocabulary and version from a weights directory."""
    d = Path(weights_dir) if weights_dir is not None else DEFAULT_WEIGHTS_DIR
    meta = json.loads((d / META_FILE).read_text())
    vocab = Vocab(meta["vocab"])
    if vocab.itos != meta["vocab"]:
        raise ValueError(f"{d / META_FILE}: vocabulary is not in canonical order")
    cfg = ModelConfig.from_dict(meta["config"])
    model = SimCapNet(cfg)
    state = torch.load(d / WEIGHTS_FILE, map_location="cpu", weights_only=True)
    model.load_state_dict(state)
    model.eval()
    return model, vocab, str(meta.get("version", "unknown"))


class SimcapCaptioner(BatchCaptioner):
    """Captions crops (``kind="object"``) and whole frames (``kind="frame"``)."""

    backend = "simcap"

    def __init__(self, weights_dir: Path | None = None, *, threads: int = 1, crop_size: int | None = None) -> None:
        super().__init__()
        torch.set_num_threads(threads)
        self.model, self.vocab, version = load_model(weights_dir)
        self.logit_bias = bias_vector(self.vocab, load_meta(weights_dir).get("logit_bias"))
        self.model_version = f"simcap-{version}"
        cfg = self.model.cfg
        self.crop_size = int(crop_size or cfg.crop_size)
        if self.crop_size != cfg.crop_size:
            log.warning("crop_size %d differs from the %d px simcap was trained on", self.crop_size, cfg.crop_size)
        self.frame_size = cfg.frame_size
        n = sum(p.numel() for p in self.model.parameters())
        log.info("simcap %s loaded: %d parameters, crops %d px, frames %d px", version, n, self.crop_size,
                 self.frame_size)

    def _features(self, images: Sequence[np.ndarray], size: int) -> torch.Tensor:
        """Encoder features (B, feature_dim) of ``images`` resized to ``size`` px."""
        return self.model.encoder(images_to_tensor([resize(check_rgb(im), size) for im in images]))

    def _decode(self, feats: torch.Tensor, bos: list[int]) -> list[str]:
        ids = self.model.decode(feats, torch.tensor(bos), self.vocab.eos, logit_bias=self.logit_bias)
        return [self.vocab.decode(row.tolist()) for row in ids]

    @torch.inference_mode()
    def _generate(self, images: Sequence[np.ndarray], kind: CaptionKind) -> list[str]:
        size = self.frame_size if kind == "frame" else self.crop_size
        return self._decode(self._features(images, size), [self.vocab.bos(kind)] * len(images))

    @torch.inference_mode()
    def _generate_frame_and_crops(self, frame_rgb: np.ndarray, crops: Sequence[np.ndarray]) -> list[str]:
        """One decode for the frame and its crops: each size through the encoder, then every
        caption word by word together (the frame's row starts with ``<frame>``)."""
        feats = [self._features([frame_rgb], self.frame_size)]
        if len(crops):
            feats.append(self._features(crops, self.crop_size))
        return self._decode(torch.cat(feats), [self.vocab.bos("frame")] + [self.vocab.bos("object")] * len(crops))
