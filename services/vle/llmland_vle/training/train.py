"""Train simcap on a :class:`RenderSet` (CPU, seeded, reproducible for a given thread count)."""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor, nn
from torch.nn import functional as F  # noqa: N812

from ..captions import CLASSES, WORD_CLASS
from ..simcap.model import ModelConfig, SimCapNet
from ..simcap.vocab import Vocab, tokenize
from .data import RenderSet

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TrainConfig:
    seed: int = 0
    epochs: int = 7
    batch_size: int = 64
    lr: float = 3e-3
    weight_decay: float = 1e-4
    threads: int = 1  # one thread: deterministic and robust on a shared CPU
    class_word_weight: float = 3.0  # loss weight of class words in a caption
    person_weight: float = 3.0  # extra loss weight of person crops (missing a person is costly)
    aux_weight: float = 0.5  # auxiliary class head
    aux_person_weight: float = 4.0  # class weight of persons in the auxiliary head
    frame_batches_every: int = 4  # one frame batch after this many crop batches


def _encode(
    vocab: Vocab, texts: list[str], kinds: list[str], max_len: int, class_word_weight: float = 3.0
) -> tuple[Tensor, Tensor, Tensor]:
    """tokens_in (N, T), targets (N, T) with -100 padding, per-token weights (N, T)."""
    n, t = len(texts), max_len + 1
    tok_in = torch.full((n, t), vocab.pad, dtype=torch.long)
    tgt = torch.full((n, t), -100, dtype=torch.long)
    wts = torch.zeros((n, t))
    for i, (text, kind) in enumerate(zip(texts, kinds, strict=True)):
        ids = vocab.encode(text)[:t]
        words = tokenize(text)
        tok_in[i, 0] = vocab.bos(kind)
        tok_in[i, 1 : len(ids)] = torch.tensor(ids[:-1], dtype=torch.long)
        tgt[i, : len(ids)] = torch.tensor(ids, dtype=torch.long)
        wts[i, : len(ids)] = 1.0
        for j, w in enumerate(words[: len(ids)]):
            if w in WORD_CLASS:
                wts[i, j] = class_word_weight
    return tok_in, tgt, wts


def _augment(x: Tensor, gen: torch.Generator) -> Tensor:
    """Random flip, zoom (0.85-1.1), shift (±8%), brightness and tint, per image."""
    n = x.shape[0]
    flip = torch.rand(n, generator=gen) < 0.5
    x = torch.where(flip[:, None, None, None], x.flip(3), x)
    scale = 0.85 + 0.25 * torch.rand(n, generator=gen)
    shift = 0.16 * (torch.rand(n, 2, generator=gen) - 0.5)
    theta = torch.zeros(n, 2, 3)
    theta[:, 0, 0], theta[:, 1, 1], theta[:, :, 2] = scale, scale, shift
    grid = F.affine_grid(theta, list(x.shape), align_corners=False)
    x = F.grid_sample(x, grid, mode="bilinear", padding_mode="border", align_corners=False)
    gain = 0.88 + 0.24 * torch.rand(n, 1, 1, 1, generator=gen)
    tint = 0.96 + 0.08 * torch.rand(n, 3, 1, 1, generator=gen)
    return (x * gain * tint).clamp(0.0, 255.0)


@dataclass(frozen=True)
class _TrainSet:
    """Tensors of one training run: object crops (N, 3, H, W) with token inputs, targets and
    weights and class indices; whole frames likewise; per-crop draw weights; class-head weights."""

    crops: Tensor
    c_in: Tensor
    c_tgt: Tensor
    c_w: Tensor
    cls_idx: Tensor
    frames: Tensor
    f_in: Tensor
    f_tgt: Tensor
    f_w: Tensor
    draw_w: Tensor
    aux_w: Tensor


def _train_set(data: RenderSet, vocab: Vocab, mcfg: ModelConfig, tcfg: TrainConfig) -> _TrainSet:
    keep = [i for i, c in enumerate(data.classes) if c]
    crops = torch.from_numpy(np.stack([data.crops[i] for i in keep])).permute(0, 3, 1, 2).contiguous()
    classes = [data.classes[i] for i in keep]
    texts = [data.captions[i] for i in keep]
    c_in, c_tgt, c_w = _encode(vocab, texts, ["object"] * len(keep), mcfg.max_len, tcfg.class_word_weight)
    cls_idx = torch.tensor([CLASSES.index(c) for c in classes], dtype=torch.long)
    sample_w = torch.where(cls_idx == CLASSES.index("person"), tcfg.person_weight, 1.0)
    c_w = c_w * sample_w[:, None]
    frames = torch.from_numpy(np.stack(data.frames)).permute(0, 3, 1, 2).contiguous()
    f_in, f_tgt, f_w = _encode(
        vocab, data.frame_captions, ["frame"] * len(data.frames), mcfg.max_len, tcfg.class_word_weight
    )
    # class-balanced sampling: weight 1/sqrt(class frequency)
    freq = torch.bincount(cls_idx, minlength=len(CLASSES)).float().clamp(min=1.0)
    draw_w = (1.0 / freq.sqrt())[cls_idx]
    aux_w = torch.ones(len(CLASSES))
    aux_w[CLASSES.index("person")] = tcfg.aux_person_weight
    return _TrainSet(crops, c_in, c_tgt, c_w, cls_idx, frames, f_in, f_tgt, f_w, draw_w, aux_w)


def train(data: RenderSet, vocab: Vocab, mcfg: ModelConfig, tcfg: TrainConfig) -> SimCapNet:
    """Train a fresh model; returns it in eval mode."""
    torch.manual_seed(tcfg.seed)
    torch.set_num_threads(tcfg.threads)
    gen = torch.Generator().manual_seed(tcfg.seed)
    ts = _train_set(data, vocab, mcfg, tcfg)
    crops, c_in, c_tgt, c_w, cls_idx = ts.crops, ts.c_in, ts.c_tgt, ts.c_w, ts.cls_idx
    frames, f_in, f_tgt, f_w, draw_w = ts.frames, ts.f_in, ts.f_tgt, ts.f_w, ts.draw_w
    n_crops = len(crops)

    model = SimCapNet(mcfg)
    opt = torch.optim.AdamW(model.parameters(), lr=tcfg.lr, weight_decay=tcfg.weight_decay)
    n_batches = math.ceil(n_crops / tcfg.batch_size)
    total = tcfg.epochs * (n_batches + n_batches // tcfg.frame_batches_every)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=tcfg.lr, total_steps=total, pct_start=0.15)
    ce = nn.CrossEntropyLoss(reduction="none")
    aux_ce = nn.CrossEntropyLoss(weight=ts.aux_w)
    log.info("training on %d crops + %d frames, %d epochs, %d steps", n_crops, len(data.frames), tcfg.epochs, total)
    t0 = time.perf_counter()
    model.train()

    def step(x: Tensor, t_in: Tensor, tgt: Tensor, w: Tensor, cls: Tensor | None) -> float:
        logits, cls_logits = model(_augment(x.float(), gen), t_in)
        tok_loss = ce(logits.reshape(-1, logits.shape[-1]), tgt.reshape(-1)) * w.reshape(-1)
        loss = tok_loss.sum() / w.sum().clamp(min=1.0)
        if cls is not None:
            loss = loss + tcfg.aux_weight * aux_ce(cls_logits, cls)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        sched.step()
        return float(loss.detach())

    for epoch in range(tcfg.epochs):
        order = torch.multinomial(draw_w, n_crops, replacement=True, generator=gen)
        f_order = torch.randperm(len(data.frames), generator=gen)
        losses = []
        for b in range(n_batches):
            idx = order[b * tcfg.batch_size : (b + 1) * tcfg.batch_size]
            losses.append(step(crops[idx], c_in[idx], c_tgt[idx], c_w[idx], cls_idx[idx]))
            if (b + 1) % tcfg.frame_batches_every == 0:
                k = (b // tcfg.frame_batches_every) * tcfg.batch_size % max(len(f_order), 1)
                fi = f_order[k : k + tcfg.batch_size]
                if len(fi):
                    step(frames[fi], f_in[fi], f_tgt[fi], f_w[fi], None)
        log.info("epoch %d/%d: loss %.4f (%.0f s)", epoch + 1, tcfg.epochs, float(np.mean(losses)),
                 time.perf_counter() - t0)
    model.eval()
    return model
