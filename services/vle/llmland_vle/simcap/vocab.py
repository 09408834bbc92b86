"""Word vocabulary of the simcap decoder (a JSON list of words, specials first)."""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

PAD, BOS_OBJECT, BOS_FRAME, EOS, UNK = "<pad>", "<object>", "<frame>", "<eos>", "<unk>"
SPECIALS = (PAD, BOS_OBJECT, BOS_FRAME, EOS, UNK)


def tokenize(text: str) -> list[str]:
    """Lower-case words; commas are words of their own."""
    return text.lower().replace(",", " , ").split()


def detokenize(words: Iterable[str]) -> str:
    return " ".join(words).replace(" , ", ", ")


class Vocab:
    """Maps words to ids and back. Ids 0-4 are the special tokens in :data:`SPECIALS`."""

    def __init__(self, words: Sequence[str]) -> None:
        words = [w for w in words if w not in SPECIALS]
        self.itos: list[str] = list(SPECIALS) + sorted(set(words))
        self.stoi = {w: i for i, w in enumerate(self.itos)}

    def __len__(self) -> int:
        return len(self.itos)

    @property
    def pad(self) -> int:
        return self.stoi[PAD]

    @property
    def eos(self) -> int:
        return self.stoi[EOS]

    def bos(self, kind: str) -> int:
        return self.stoi[BOS_FRAME if kind == "frame" else BOS_OBJECT]

    def encode(self, text: str) -> list[int]:
        """Word ids of ``text`` followed by ``<eos>`` (no BOS)."""
        unk = self.stoi[UNK]
        return [self.stoi.get(w, unk) for w in tokenize(text)] + [self.eos]

    def decode(self, ids: Iterable[int]) -> str:
        """Text of ids up to the first ``<eos>``; specials are skipped."""
        words = []
        for i in ids:
            i = int(i)
            if i == self.eos:
                break
            if 0 <= i < len(self.itos) and self.itos[i] not in SPECIALS:
                words.append(self.itos[i])
        return detokenize(words)

    def save(self, path: Path) -> None:
        path.write_text(json.dumps(self.itos, indent=0) + "\n")

    @classmethod
    def load(cls, path: Path) -> Vocab:
        words = json.loads(Path(path).read_text())
        if not isinstance(words, list) or list(words[: len(SPECIALS)]) != list(SPECIALS):
            raise ValueError(f"{path}: not a simcap vocabulary")
        return cls([str(w) for w in words])
