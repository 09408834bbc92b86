"""simcap network: a small CNN image encoder and a GRU word decoder (greedy, batched).

Encoder: a 4×4 stride-4 patch stem and four 3×3 conv blocks (BatchNorm, ReLU, 2×2 max
pool on the first three), global average pooling, then a linear projection. The same
encoder reads 96×96 object crops and 128×128 whole frames; the decoder's first token
(``<object>`` or ``<frame>``) says which caption style to produce. An auxiliary class head
on the image feature is used as an extra training signal only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import Tensor, nn

from ..captions import CLASSES


@dataclass(frozen=True)
class ModelConfig:
    vocab_size: int
    channels: tuple[int, ...] = (24, 32, 64, 96, 128)
    feature_dim: int = 128
    embed_dim: int = 64
    hidden_dim: int = 192
    max_len: int = 16
    crop_size: int = 96
    frame_size: int = 128
    n_classes: int = len(CLASSES)

    def to_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["channels"] = list(self.channels)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, object]) -> ModelConfig:
        d = dict(d)
        channels = d["channels"]
        assert isinstance(channels, list | tuple)
        d["channels"] = tuple(int(c) for c in channels)
        return cls(**d)  # type: ignore[arg-type]


def _block(c_in: int, c_out: int, pool: bool) -> list[nn.Module]:
    layers: list[nn.Module] = [nn.Conv2d(c_in, c_out, 3, padding=1, bias=False), nn.BatchNorm2d(c_out), nn.ReLU()]
    if pool:
        layers.append(nn.MaxPool2d(2))
    return layers


class Encoder(nn.Module):
    def __init__(self, cfg: ModelConfig) -> None:
        super().__init__()
        ch = cfg.channels
        layers: list[nn.Module] = [nn.Conv2d(3, ch[0], 4, stride=4, bias=False), nn.BatchNorm2d(ch[0]), nn.ReLU()]
        for i in range(1, len(ch)):
            layers += _block(ch[i - 1], ch[i], pool=i < len(ch) - 1)
        self.body = nn.Sequential(*layers)
        self.proj = nn.Sequential(nn.Linear(ch[-1], cfg.feature_dim), nn.ReLU())

    def forward(self, images: Tensor) -> Tensor:
        """uint8-range float images (B, 3, H, W) -> features (B, feature_dim)."""
        x = self.body(images / 127.5 - 1.0)
        return self.proj(x.mean(dim=(2, 3)))


class SimCapNet(nn.Module):
    def __init__(self, cfg: ModelConfig) -> None:
        super().__init__()
        self.cfg = cfg
        self.encoder = Encoder(cfg)
        self.embed = nn.Embedding(cfg.vocab_size, cfg.embed_dim)
        self.init_h = nn.Linear(cfg.feature_dim, cfg.hidden_dim)
        self.gru = nn.GRU(cfg.embed_dim + cfg.feature_dim, cfg.hidden_dim, batch_first=True)
        self.out = nn.Linear(cfg.hidden_dim, cfg.vocab_size)
        self.cls_head = nn.Linear(cfg.feature_dim, cfg.n_classes)

    def _step_inputs(self, tokens: Tensor, feat: Tensor) -> Tensor:
        emb = self.embed(tokens)  # (B, T, E)
        return torch.cat([emb, feat[:, None, :].expand(-1, emb.shape[1], -1)], dim=2)

    def forward(self, images: Tensor, tokens_in: Tensor) -> tuple[Tensor, Tensor]:
        """Teacher forcing: images (B, 3, H, W), tokens_in (B, T) starting with a BOS.

        Returns word logits (B, T, V) and class logits (B, n_classes).
        """
        feat = self.encoder(images)
        h0 = torch.tanh(self.init_h(feat))[None]
        out, _ = self.gru(self._step_inputs(tokens_in, feat), h0)
        return self.out(out), self.cls_head(feat)

    @torch.inference_mode()
    def greedy(
        self, images: Tensor, bos: int, eos: int, max_len: int | None = None, logit_bias: Tensor | None = None
    ) -> Tensor:
        """Greedy decoding for a batch: (B, 3, H, W) -> word ids (B, <= max_len).

        ``logit_bias`` (V,) is added to the word logits at every step (e.g. to favour
        "person" when it is a close call: missing a person is the costly error).
        """
        feat = self.encoder(images)
        return self.decode(feat, torch.full((feat.shape[0],), bos, dtype=torch.long), eos, max_len, logit_bias)

    @torch.inference_mode()
    def decode(
        self, feat: Tensor, bos: Tensor, eos: int, max_len: int | None = None, logit_bias: Tensor | None = None
    ) -> Tensor:
        """Greedy decoding from image features: ``feat`` (B, feature_dim), ``bos`` (B,) each row's
        first token (rows of different caption styles decode together) -> word ids (B, <= max_len).

        The GRU step is written out (PyTorch's ``nn.GRU`` equations, its weights): the input
        projection of a step is a row of a per-word table plus the image feature's projection,
        both computed once per call, so a step costs two small matrix products instead of a
        module call on the concatenated input. Same words as stepping ``self.gru``.
        """
        n = feat.shape[0]
        max_len = max_len or self.cfg.max_len
        e = self.cfg.embed_dim
        w_ih, w_hh, b_ih, b_hh = self.gru.all_weights[0]  # layer 0: W_ih (3H, E+F), W_hh (3H, H), b_ih, b_hh
        word_in = torch.addmm(b_ih, self.embed.weight, w_ih[:, :e].T)  # (V, 3H): embed → gates
        feat_in = feat @ w_ih[:, e:].T  # (B, 3H): the image part of every step's input
        out_b = self.out.bias if logit_bias is None else self.out.bias + logit_bias
        h = torch.tanh(self.init_h(feat))
        tok = bos
        done = torch.zeros(n, dtype=torch.bool)
        steps = []
        for _ in range(max_len):
            i_r, i_z, i_n = (word_in[tok] + feat_in).chunk(3, dim=1)
            h_r, h_z, h_n = torch.addmm(b_hh, h, w_hh.T).chunk(3, dim=1)
            r, z = torch.sigmoid(i_r + h_r), torch.sigmoid(i_z + h_z)
            cand = torch.tanh(i_n + r * h_n)
            h = cand + z * (h - cand)  # (1 - z) * n + z * h
            nxt = torch.addmm(out_b, h, self.out.weight.T).argmax(dim=1)
            nxt = torch.where(done, torch.full_like(nxt, eos), nxt)
            steps.append(nxt)
            done |= nxt == eos
            if bool(done.all()):
                break
            tok = nxt
        return torch.stack(steps, dim=1)


def images_to_tensor(images: Sequence[np.ndarray] | np.ndarray) -> Tensor:
    """Stack (S, S, 3) uint8 arrays into a float (B, 3, S, S) tensor (values 0-255)."""
    arr = images if isinstance(images, np.ndarray) else np.stack(list(images))
    return torch.from_numpy(np.ascontiguousarray(arr)).permute(0, 3, 1, 2).float().contiguous()
