"""Evaluated prompt prefixes kept on disk, so a restarted reasoner does not evaluate them again.

Every reasoner start (and every restart of its LLM worker) evaluated the fixed prompt prefix —
426 tokens for ``rag``, ≈ 4.5 s of llama.cpp on one core of the 2-core machine, a third of the
service's start-up. The KV state that evaluation leaves is a function of the tokens, the model
file, the context size and the llama.cpp build alone, so it is saved once
(``llama_state_seq_get_data``, ≈ 10 MB for SmolLM2-135M) and restored on the next start
(``llama_state_seq_set_data``) — the same restore :class:`~.llm.LlamaCppBackend` already does in
memory when it switches between prompts.

The file name is a digest of everything the state depends on: the prefix's tokens, the GGUF
file (path, size, modification time), ``n_ctx`` and ``n_batch``, the llama-cpp-python version and
its shared libraries (path, size, modification time: the portable and a native build compute
slightly different floats, and a rebuilt runtime gets new files). Each file starts with the
SHA-256 of its state: a file that cannot be read, does not match its digest or cannot be
restored is ignored (and removed) and the prefix evaluated as before; writes go to a temporary
file renamed into place, so concurrent services never read half a file. At most
:data:`MAX_FILES` are kept.
"""

from __future__ import annotations

import hashlib
import logging
import os
from pathlib import Path

from .checked_file import DamagedFileError, read_checked, remove, write_checked

log = logging.getLogger(__name__)

#: state files kept per folder (the newest by modification time); a few prompts × models
MAX_FILES = 16
SUFFIX = ".kvstate"


def default_state_dir() -> Path:
    return Path.home() / ".cache" / "llmland" / "llm-prefix-state"


def _file_identity(path: Path) -> str:
    st = path.stat()
    return f"{path.resolve()}:{st.st_size}:{st.st_mtime_ns}"


def runtime_identity() -> str:
    """The llama-cpp-python version and the identity of every shared library it ships."""
    import llama_cpp

    lib_dir = Path(llama_cpp.__file__).parent / "lib"
    libs = sorted(p for pattern in ("*.so*", "*.dylib", "*.dll") for p in lib_dir.glob(pattern)
                  if p.is_file()) if lib_dir.is_dir() else []
    return ";".join([f"llama-cpp-python {llama_cpp.__version__}", *(_file_identity(p) for p in libs)])


class PrefixStateStore:
    """Saved KV states of evaluated prompt prefixes for one model, context and runtime."""

    def __init__(self, folder: Path, model_path: Path, n_ctx: int, n_batch: int) -> None:
        self.folder = folder
        self._context = f"{runtime_identity()}|{_file_identity(model_path)}|n_ctx={n_ctx}|n_batch={n_batch}"

    def path(self, tokens: list[int]) -> Path:
        digest = hashlib.sha256(f"{self._context}|{','.join(map(str, tokens))}".encode()).hexdigest()[:32]
        return self.folder / f"{digest}{SUFFIX}"

    def load(self, tokens: list[int]) -> bytes | None:
        """The saved state for ``tokens``, or None (never saved, unreadable or damaged)."""
        path = self.path(tokens)
        try:
            data = read_checked(path)
        except DamagedFileError:
            log.warning("prompt prefix state %s is damaged; ignored", path)
            self.discard(tokens)
            return None
        if data is not None:
            try:
                os.utime(path)  # recently used: kept by the pruning below
            except OSError:
                pass
        return data

    def save(self, tokens: list[int], data: bytes) -> None:
        """Write the state atomically; a folder that cannot be written is only logged."""
        try:
            write_checked(self.path(tokens), data)
        except OSError as exc:
            log.info("prompt prefix state not saved in %s: %s", self.folder, exc)
            return
        self._prune()

    def discard(self, tokens: list[int]) -> None:
        """Forget a state that could not be restored."""
        remove(self.path(tokens))

    def _prune(self) -> None:
        try:
            files = sorted(self.folder.glob(f"*{SUFFIX}"), key=lambda p: p.stat().st_mtime_ns, reverse=True)
            for old in files[MAX_FILES:]:
                remove(old)
        except OSError:  # another process pruned the same file first
            pass
