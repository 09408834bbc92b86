"""The service's frame callback with a fake bus (no Zenoh): what it counts, what it hands on."""

from __future__ import annotations

from typing import Any

from llmland_vle.service import VleService
from llmland_vle.settings import VleSettings


class _FakeBus:
    """Records wiring calls; publishes nowhere."""

    def __getattr__(self, _name: str) -> Any:
        return lambda *_a, **_k: None


class _HeldWorker:
    """Stands in for the latest-frame worker while it is busy: keeps what it is offered."""

    def __init__(self) -> None:
        self.items: list[tuple[bytes, float]] = []

    def submit(self, item: tuple[bytes, float]) -> None:
        self.items.append(item)

    def close(self) -> None:
        pass


def test_a_malformed_frame_is_counted_even_if_a_newer_frame_would_replace_it(
    stub: Any, frames: list[bytes]
) -> None:
    service = VleService(VleSettings(drone_id="dfake"), _FakeBus(), captioner=stub)  # type: ignore[arg-type]
    service.worker.close()
    held = _HeldWorker()
    service.worker = held  # type: ignore[assignment]
    try:
        for garbage in (b"garbage frame", b"", frames[1][:6]):
            service._on_frame("k", garbage)
        service._on_frame("k", frames[1])
        assert service.processor.dropped["malformed"] == 3
        assert [p for p, _ in held.items] == [frames[1]]  # only the good frame reaches the worker
    finally:
        service.close()
