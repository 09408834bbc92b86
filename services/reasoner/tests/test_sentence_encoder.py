"""The numpy BERT encoder computes what sentence-transformers computes, on the same files."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from llmland_reasoner import embedding
from llmland_reasoner.embedding import default_model_dir, load_sentence_model
from llmland_reasoner.sentence_encoder import BertSentenceEncoder, UnsupportedEncoderError

#: float32 through six layers in another BLAS: agreement to about 1e-6 (measured 2e-7)
TOLERANCE = 1e-5

CAPTIONS = [
    "a man walking a dog across a busy street",
    "A red pickup truck parked next to an oak tree.",
    "",  # only [CLS] [SEP]
    "tuk-tuk",
    "a crowd at an outdoor festival with food stalls " * 40,  # past max_seq_length: truncated
    "Ünïcödé café signage, 3 bicycles & a scooter!",
]


@pytest.fixture(scope="module")
def reference() -> Any:
    sentence_transformers = pytest.importorskip("sentence_transformers")
    embedding.force_offline()
    return sentence_transformers.SentenceTransformer(str(default_model_dir()), device="cpu")


def _copy_model(tmp_path: Path) -> Path:
    """The default model's folder, its configs copied (to edit), its weights linked."""
    folder = tmp_path / "model"
    shutil.copytree(default_model_dir(), folder, ignore=shutil.ignore_patterns("*.safetensors"))
    (folder / "model.safetensors").symlink_to(default_model_dir() / "model.safetensors")
    return folder


def test_vectors_match_sentence_transformers(reference: Any) -> None:
    encoder = BertSentenceEncoder(default_model_dir())
    ours = encoder.encode(CAPTIONS, batch_size=4)  # batches of mixed lengths: padding must not leak
    theirs = reference.encode(CAPTIONS, normalize_embeddings=True)
    assert ours.shape == (len(CAPTIONS), 384) and ours.dtype == np.float32
    assert np.abs(ours - theirs).max() < TOLERANCE
    np.testing.assert_allclose(np.linalg.norm(ours, axis=1), 1.0, atol=1e-6)


def test_a_caption_alone_and_in_a_batch_give_the_same_vector() -> None:
    encoder = BertSentenceEncoder(default_model_dir())
    batch = encoder.encode(CAPTIONS)
    alone = np.stack([encoder.encode([c])[0] for c in CAPTIONS])
    assert np.abs(batch - alone).max() < TOLERANCE


def test_cls_pooling_matches_sentence_transformers(tmp_path: Path) -> None:
    st = pytest.importorskip("sentence_transformers")
    folder = _copy_model(tmp_path)
    pooling = json.loads((folder / "1_Pooling" / "config.json").read_text())
    pooling.update(pooling_mode_cls_token=True, pooling_mode_mean_tokens=False)
    (folder / "1_Pooling" / "config.json").write_text(json.dumps(pooling))
    ours = BertSentenceEncoder(folder).encode(CAPTIONS[:3])
    theirs = st.SentenceTransformer(str(folder), device="cpu").encode(CAPTIONS[:3], normalize_embeddings=True)
    assert np.abs(ours - theirs).max() < TOLERANCE


def test_an_empty_list_gives_an_empty_array() -> None:
    assert BertSentenceEncoder(default_model_dir()).encode([]).shape == (0, 384)


@pytest.mark.parametrize(("key", "value"), [("model_type", "roberta"), ("hidden_act", "relu"),
                                            ("position_embedding_type", "relative_key")])
def test_other_architectures_are_refused_by_name(tmp_path: Path, key: str, value: str) -> None:
    folder = _copy_model(tmp_path)
    config = json.loads((folder / "config.json").read_text())
    config[key] = value
    (folder / "config.json").write_text(json.dumps(config))
    with pytest.raises(UnsupportedEncoderError, match=key):
        BertSentenceEncoder(folder)
    with pytest.raises(UnsupportedEncoderError):
        load_sentence_model(folder, backend="numpy")


def test_auto_falls_back_to_sentence_transformers_for_what_numpy_cannot_run(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = _copy_model(tmp_path)
    (folder / "model.safetensors").unlink()  # e.g. a pytorch_model.bin-only model
    loaded: list[Path] = []

    def fake_load(path: Path, n_threads: int) -> str:
        loaded.append(path)
        return "sentence-transformers model"

    monkeypatch.setattr(embedding, "_load_sentence_transformers", fake_load)
    assert load_sentence_model(folder, backend="auto") == "sentence-transformers model"
    assert loaded == [folder]
    assert isinstance(load_sentence_model(None, backend="auto"), BertSentenceEncoder)  # the default is BERT


def test_weights_missing_a_layer_are_refused(tmp_path: Path) -> None:
    folder = _copy_model(tmp_path)
    config = json.loads((folder / "config.json").read_text())
    config["num_hidden_layers"] += 1  # the file holds one layer fewer than the config says
    (folder / "config.json").write_text(json.dumps(config))
    with pytest.raises(UnsupportedEncoderError, match="encoder.layer.6"):
        BertSentenceEncoder(folder)
