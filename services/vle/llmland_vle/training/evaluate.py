"""Held-out evaluation of simcap: class words, person recall, colour / motion words, frames."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor

from ..captions import COLOURS, WORD_CLASS, caption_class
from ..simcap.model import SimCapNet, images_to_tensor
from ..simcap.vocab import Vocab, tokenize
from .data import RenderSet

MOTION = ("walking", "standing", "driving", "parked")


def predict(
    model: SimCapNet, vocab: Vocab, images: Sequence[np.ndarray], kind: str, bias: Tensor | None = None,
    batch: int = 128,
) -> list[str]:
    out: list[str] = []
    for i in range(0, len(images), batch):
        x = images_to_tensor(list(images[i : i + batch]))
        with torch.inference_mode():
            ids = model.greedy(x, vocab.bos(kind), vocab.eos, logit_bias=bias)
        out += [vocab.decode(r.tolist()) for r in ids]
    return out


def _word_of(text: str, options: Sequence[str]) -> str | None:
    return next((w for w in tokenize(text) if w in options), None)


def _class_metrics(truth: list[str], pred: list[str]) -> dict[str, Any]:
    n = len(truth)
    if n == 0:
        return {"n": 0}
    pred_cls = [caption_class(p) or "none" for p in pred]
    correct = sum(t == p for t, p in zip(truth, pred_cls, strict=True))
    persons = [i for i, t in enumerate(truth) if t == "person"]
    said_person = [i for i, p in enumerate(pred_cls) if p == "person"]
    per_class = {}
    for c in sorted(set(truth)):
        idx = [i for i, t in enumerate(truth) if t == c]
        per_class[c] = round(sum(pred_cls[i] == c for i in idx) / len(idx), 4)
    return {
        "n": n,
        "class_acc": round(correct / n, 4),
        "n_person": len(persons),
        "person_recall": round(sum(pred_cls[i] == "person" for i in persons) / max(len(persons), 1), 4),
        "person_precision": round(sum(truth[i] == "person" for i in said_person) / max(len(said_person), 1), 4),
        "per_class_acc": per_class,
    }


def evaluate(model: SimCapNet, vocab: Vocab, data: RenderSet, bias: Tensor | None = None) -> dict[str, Any]:
    """Metrics on a held-out :class:`RenderSet`.

    ``seg_crops``: crops boxed by segmentation. ``blob_crops``: depth-blob crops whose truth
    object, found by world position, is confirmed by segmentation to fill >= 5% of the box
    (or 30 px). ``blob_crops_raw``: every position match, confirmed or not (a terrain blob
    whose centre lies under a tree that is not even in the crop counts as a "tree").
    """
    model.eval()
    preds = predict(model, vocab, data.crops, "object", bias)
    res: dict[str, Any] = {}
    seg = [i for i, s in enumerate(data.sources) if s == "seg"]
    raw = [i for i, s in enumerate(data.sources) if s == "blob" and data.pos_classes[i] not in ("", "ground")]
    blob = [i for i in raw if data.classes[i] == data.pos_classes[i]]
    ground = [i for i, s in enumerate(data.sources) if s == "blob" and data.pos_classes[i] == "ground"]
    res["seg_crops"] = _class_metrics([data.classes[i] for i in seg], [preds[i] for i in seg])
    res["blob_crops"] = _class_metrics([data.pos_classes[i] for i in blob], [preds[i] for i in blob])
    res["blob_crops_raw"] = _class_metrics([data.pos_classes[i] for i in raw], [preds[i] for i in raw])
    res["ground_blobs"] = {
        "n": len(ground),
        "acc": round(sum(caption_class(preds[i]) == "ground" for i in ground) / max(len(ground), 1), 4),
    }
    labelled = [i for i in seg + blob if data.captions[i]]
    res["exact_caption"] = round(sum(preds[i] == data.captions[i] for i in labelled) / max(len(labelled), 1), 4)
    for name, words in (("colour_acc", COLOURS), ("motion_acc", MOTION)):
        pairs = [(_word_of(data.captions[i], words), _word_of(preds[i], words)) for i in labelled]
        pairs = [(t, p) for t, p in pairs if t is not None]
        res[name] = round(sum(t == p for t, p in pairs) / max(len(pairs), 1), 4)
    fpred = predict(model, vocab, data.frames, "frame", bias)
    tp = fp = fn = 0
    for t_text, p_text in zip(data.frame_captions, fpred, strict=True):
        t_set = {WORD_CLASS[w] for w in tokenize(t_text) if w in WORD_CLASS}
        p_set = {WORD_CLASS[w] for w in tokenize(p_text) if w in WORD_CLASS}
        tp, fp, fn = tp + len(t_set & p_set), fp + len(p_set - t_set), fn + len(t_set - p_set)
    res["frames"] = {
        "n": len(fpred),
        "mention_precision": round(tp / max(tp + fp, 1), 4),
        "mention_recall": round(tp / max(tp + fn, 1), 4),
        "exact": round(sum(a == b for a, b in zip(data.frame_captions, fpred, strict=True)) / max(len(fpred), 1), 4),
    }
    return res


def choose_person_bias(
    model: SimCapNet, vocab: Vocab, val: RenderSet, target_recall: float = 0.995,
    grid: Sequence[float] = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0),
) -> tuple[float, list[dict[str, float]]]:
    """Logit bias for the word "person", chosen on validation data (not the held-out set).

    The smallest bias whose person recall reaches ``target_recall`` while class accuracy
    stays within one point of the unbiased model; else the bias with the best recall.
    """
    idx = [i for i, c in enumerate(val.classes) if c]
    truth = [val.classes[i] for i in idx]
    crops = [val.crops[i] for i in idx]
    rows: list[dict[str, float]] = []
    for b in grid:
        bias = torch.zeros(len(vocab))
        bias[vocab.stoi["person"]] = b
        m = _class_metrics(truth, predict(model, vocab, crops, "object", bias))
        rows.append({"bias": b, "class_acc": m["class_acc"], "person_recall": m["person_recall"]})
    acc0 = rows[0]["class_acc"]
    ok = [r for r in rows if r["person_recall"] >= target_recall and r["class_acc"] >= acc0 - 0.01]
    best = ok[0] if ok else max(rows, key=lambda r: (r["person_recall"], -r["bias"]))
    return float(best["bias"]), rows
