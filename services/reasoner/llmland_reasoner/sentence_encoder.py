"""A BERT sentence encoder in numpy: what sentence-transformers computes for a BERT model
(all-MiniLM-L6-v2, bge-small…), without importing torch or transformers.

Why it exists: the reasoner spent 6–8 s of its 12–14 s start-up importing sentence-transformers
(transformers, torch, scikit-learn) to run a 22 M-parameter encoder on one short caption at a
time. This module reads the same files (``config.json``, ``model.safetensors``,
``tokenizer.json``, ``1_Pooling/config.json``, ``modules.json``) and computes the same vectors:
the HF ``tokenizers`` library tokenises, numpy runs the encoder. It serves only the architecture
it was written for (``model_type: bert``, absolute positions, GELU); anything else raises
:class:`UnsupportedEncoderError` and the caller loads sentence-transformers instead
(``embedding.load_sentence_model``). ``tests/test_sentence_encoder.py`` checks it against
sentence-transformers on the same model.

The encoder, per layer (Devlin et al. 2019, "BERT", §3; Vaswani et al. 2017 §3.2 for the
attention): ``h = LN(x + W_o·MHA(x))``, ``x' = LN(h + W_2·GELU(W_1·h))``, with GELU the exact
``x·Φ(x)`` form (``hidden_act: gelu``). The sentence vector is the mean (or ``[CLS]``) of the
last layer over the non-padding tokens (Reimers & Gurevych 2019, "Sentence-BERT", §3),
L2-normalised when the model lists a ``Normalize`` module.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from safetensors.numpy import load_file
from scipy.special import ndtr
from tokenizers import Tokenizer

Array = NDArray[np.float32]

#: sentence-transformers' own default when ``sentence_bert_config.json`` names no limit
DEFAULT_MAX_SEQ_LENGTH = 256
#: the additive attention mask for padding keys (what transformers uses: the dtype's minimum)
_MASKED = np.finfo(np.float32).min


class UnsupportedEncoderError(ValueError):
    """The model folder is not a BERT sentence-transformers model this encoder can run."""


@dataclass(frozen=True)
class _Layer:
    wq: Array
    bq: Array
    wk: Array
    bk: Array
    wv: Array
    bv: Array
    wo: Array
    bo: Array
    ln1: tuple[Array, Array]
    w1: Array
    b1: Array
    w2: Array
    b2: Array
    ln2: tuple[Array, Array]


def _read_json(path: Path) -> dict | list:  # type: ignore[type-arg]
    with path.open(encoding="utf-8") as f:
        return json.load(f)  # type: ignore[no-any-return]


def _layer_norm(x: NDArray[Any], weight_bias: tuple[Array, Array], eps: float) -> Array:
    mean = x.mean(axis=-1, keepdims=True)
    var = ((x - mean) ** 2).mean(axis=-1, keepdims=True)
    return ((x - mean) / np.sqrt(var + eps) * weight_bias[0] + weight_bias[1]).astype(np.float32)


def _gelu(x: Array) -> Array:
    """Exact GELU, ``x·Φ(x)`` with Φ the standard normal CDF (Hendrycks & Gimpel 2016; what
    transformers' ``gelu`` computes as ``x/2·(1 + erf(x/√2))``)."""
    return (x * ndtr(x)).astype(np.float32)


def _softmax(x: Array) -> Array:
    e = np.exp(x - x.max(axis=-1, keepdims=True))
    return e / e.sum(axis=-1, keepdims=True)  # type: ignore[no-any-return]


class BertSentenceEncoder:
    """Sentence vectors from a local BERT sentence-transformers folder.

    ``encode(texts)`` → ``(len(texts), hidden_size)`` float32, the rows L2-normalised when
    asked (or when the model's modules end in ``Normalize``). Thread-compatible, not
    thread-safe: callers serialise (``LocalSentenceEmbedding`` holds a lock).
    """

    def __init__(self, folder: str | Path) -> None:
        folder = Path(folder)
        config = _read_json(folder / "config.json")
        assert isinstance(config, dict)
        self._check(folder, config)
        self.hidden = int(config["hidden_size"])
        self.heads = int(config["num_attention_heads"])
        self.eps = float(config.get("layer_norm_eps", 1e-12))
        modules = _read_json(folder / "modules.json") if (folder / "modules.json").exists() else []
        types = [str(m.get("type", "")) for m in modules if isinstance(m, dict)]
        self.normalize = any(t.endswith("Normalize") for t in types)
        pooling_path = folder / "1_Pooling" / "config.json"
        pooling = _read_json(pooling_path) if pooling_path.exists() else {"pooling_mode_mean_tokens": True}
        assert isinstance(pooling, dict)
        if pooling.get("pooling_mode_cls_token"):
            self.pooling = "cls"
        elif pooling.get("pooling_mode_mean_tokens"):
            self.pooling = "mean"
        else:
            raise UnsupportedEncoderError(f"{pooling_path}: only mean or [CLS] pooling is supported")
        st_config_path = folder / "sentence_bert_config.json"
        st_config = _read_json(st_config_path) if st_config_path.exists() else {}
        assert isinstance(st_config, dict)
        max_len = int(st_config.get("max_seq_length") or DEFAULT_MAX_SEQ_LENGTH)
        self.max_seq_length = min(max_len, int(config["max_position_embeddings"]))
        self.tokenizer = Tokenizer.from_file(str(folder / "tokenizer.json"))
        self.tokenizer.enable_truncation(max_length=self.max_seq_length)
        self.tokenizer.enable_padding(pad_id=int(config.get("pad_token_id", 0)))  # to the batch's longest
        self._load_weights(folder / "model.safetensors", int(config["num_hidden_layers"]))

    @staticmethod
    def _check(folder: Path, config: dict) -> None:  # type: ignore[type-arg]
        wanted = {"model_type": "bert", "hidden_act": "gelu", "position_embedding_type": "absolute"}
        for key, value in wanted.items():
            if config.get(key, value) != value:
                raise UnsupportedEncoderError(f"{folder}: {key} is {config.get(key)!r}, this encoder runs {value!r}")
        for name in ("model.safetensors", "tokenizer.json"):
            if not (folder / name).exists():
                raise UnsupportedEncoderError(f"{folder}: no {name}")

    def _load_weights(self, path: Path, n_layers: int) -> None:
        raw = load_file(str(path))
        w = {k.removeprefix("bert."): v.astype(np.float32) for k, v in raw.items()}

        def ln(prefix: str) -> tuple[Array, Array]:
            return w[f"{prefix}.LayerNorm.weight"], w[f"{prefix}.LayerNorm.bias"]

        try:
            self.word = w["embeddings.word_embeddings.weight"]
            self.position = w["embeddings.position_embeddings.weight"]
            self.token_type = w["embeddings.token_type_embeddings.weight"][0]
            self.ln_embed = ln("embeddings")
            self.layers = []
            for i in range(n_layers):
                p = f"encoder.layer.{i}"
                self.layers.append(_Layer(
                    wq=w[f"{p}.attention.self.query.weight"].T.copy(), bq=w[f"{p}.attention.self.query.bias"],
                    wk=w[f"{p}.attention.self.key.weight"].T.copy(), bk=w[f"{p}.attention.self.key.bias"],
                    wv=w[f"{p}.attention.self.value.weight"].T.copy(), bv=w[f"{p}.attention.self.value.bias"],
                    wo=w[f"{p}.attention.output.dense.weight"].T.copy(), bo=w[f"{p}.attention.output.dense.bias"],
                    ln1=ln(f"{p}.attention.output"),
                    w1=w[f"{p}.intermediate.dense.weight"].T.copy(), b1=w[f"{p}.intermediate.dense.bias"],
                    w2=w[f"{p}.output.dense.weight"].T.copy(), b2=w[f"{p}.output.dense.bias"],
                    ln2=ln(f"{p}.output"),
                ))
        except KeyError as exc:
            raise UnsupportedEncoderError(f"{path}: no weight {exc.args[0]} (not a BERT encoder)") from None

    def encode(self, texts: list[str], batch_size: int = 32, normalize_embeddings: bool = True,
               show_progress_bar: bool = False) -> Array:
        """``(len(texts), hidden)`` float32 sentence vectors (the sentence-transformers call's
        arguments; ``show_progress_bar`` is accepted and ignored)."""
        del show_progress_bar
        if not texts:
            return np.zeros((0, self.hidden), dtype=np.float32)
        out = [self._encode_batch(texts[i:i + batch_size]) for i in range(0, len(texts), batch_size)]
        vectors = np.concatenate(out, axis=0)
        if normalize_embeddings or self.normalize:
            norms = np.linalg.norm(vectors, axis=1, keepdims=True)
            vectors = vectors / np.maximum(norms, 1e-12)
        return vectors.astype(np.float32)

    def _encode_batch(self, texts: list[str]) -> Array:
        encodings = self.tokenizer.encode_batch(texts)
        ids = np.array([e.ids for e in encodings], dtype=np.int64)
        mask = np.array([e.attention_mask for e in encodings], dtype=np.float32)
        hidden = self._forward(ids, mask)
        if self.pooling == "cls":
            return hidden[:, 0, :]
        counts = np.maximum(mask.sum(axis=1, keepdims=True), 1e-9)
        return (hidden * mask[:, :, None]).sum(axis=1) / counts  # type: ignore[no-any-return]

    def _forward(self, ids: NDArray[np.int64], mask: Array) -> Array:
        """``(B, L)`` token ids and mask → ``(B, L, hidden)``; the dense layers run as one
        ``(B·L, hidden)`` matrix product each, the attention per (sentence, head) on contiguous
        blocks (numpy hands those to BLAS; strided views it multiplies itself, ≈ 10× slower)."""
        batch, length = ids.shape
        head_dim = self.hidden // self.heads
        x: Array = (self.word[ids] + self.position[:length][None, :, :] + self.token_type).astype(np.float32)
        x = _layer_norm(x.reshape(batch * length, self.hidden), self.ln_embed, self.eps)
        bias = ((1.0 - mask) * _MASKED)[:, None, None, :]  # (B, 1, 1, L): padding keys get no weight
        scale = np.float32(1.0 / np.sqrt(head_dim))

        def heads(t: Array, order: tuple[int, int, int, int]) -> Array:  # (B·L, D) -> per-head blocks
            return np.ascontiguousarray(t.reshape(batch, length, self.heads, head_dim).transpose(order))

        for layer in self.layers:
            q = heads(x @ layer.wq + layer.bq, (0, 2, 1, 3))  # (B, H, L, D/H)
            k_t = heads(x @ layer.wk + layer.bk, (0, 2, 3, 1))  # (B, H, D/H, L)
            v = heads(x @ layer.wv + layer.bv, (0, 2, 1, 3))
            weights = _softmax((q @ k_t) * scale + bias)
            context = (weights @ v).transpose(0, 2, 1, 3).reshape(batch * length, self.hidden)
            h = _layer_norm(x + context @ layer.wo + layer.bo, layer.ln1, self.eps)
            x = _layer_norm(h + _gelu(h @ layer.w1 + layer.b1) @ layer.w2 + layer.b2, layer.ln2, self.eps)
        return x.reshape(batch, length, self.hidden)
