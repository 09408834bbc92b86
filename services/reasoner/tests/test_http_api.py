"""The HTTP API against a real uvicorn server on a loopback port."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import schemathesis
import uvicorn
from hypothesis import HealthCheck, given, settings
from llmland_reasoner.engine import ReasonerEngine
from llmland_reasoner.http_api import create_app
from llmland_reasoner.resources import Resources
from llmland_reasoner.settings import ReasonerSettings
from llmland_schemas import Caption
from PIL import Image
from pydantic import SecretStr

CAPTION = Caption(text="a person walking on a grass field", backend="test", latency_ms=12.0)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _Server:
    def __init__(self, app: object) -> None:
        self.port = _free_port()
        self.server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=self.port, log_level="warning"))
        self.thread = threading.Thread(target=self.server.run, daemon=True)

    def __enter__(self) -> str:
        self.thread.start()
        deadline = time.monotonic() + 20
        while not self.server.started:
            assert time.monotonic() < deadline, "uvicorn did not start"
            time.sleep(0.05)
        return f"http://127.0.0.1:{self.port}"

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(10)


@pytest.fixture(scope="module")
def engine(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ReasonerEngine]:
    s = ReasonerSettings(index_dir=tmp_path_factory.mktemp("http-index"), n_threads=1, timeout_s=30.0,
                         max_upload_bytes=64 * 1024)
    eng = ReasonerEngine(s, Resources.load(s))
    yield eng
    eng.close()


@pytest.fixture(scope="module")
def base_url(engine: ReasonerEngine) -> Iterator[str]:
    app = create_app(engine, lambda _img: CAPTION, engine.settings)
    with _Server(app) as url:
        yield url


def _png(tmp: Path, size: int = 32) -> bytes:
    path = tmp / "img.png"
    Image.new("RGB", (size, size), (90, 160, 60)).save(path)
    return path.read_bytes()


def test_healthz_names_the_models(base_url: str) -> None:
    r = httpx.get(f"{base_url}/healthz")
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "ok" and body["models"]["llm"] and body["models"]["embedder"]


def test_reason_success_and_modes(base_url: str) -> None:
    r = httpx.post(f"{base_url}/v1/reason", json={"caption": "a woman walking a dog in the park"}, timeout=60)
    assert r.status_code == 200, r.text
    spec = r.json()
    assert spec["is_dynamic"] is True and spec["buffer_m"] >= 3.0 and spec["source"] == "rag"
    r = httpx.post(f"{base_url}/v1/reason", json={"caption": "a red brick building", "mode": "retrieval"})
    assert r.status_code == 200 and r.json()["source"] == "retrieval" and r.json()["is_dynamic"] is False


@pytest.mark.parametrize(
    "body",
    [{}, {"caption": ""}, {"caption": "   "}, {"caption": 5}, {"caption": "x", "mode": "gpt"}, {"caption": "x", "y": 1},
     {"caption": "x" * 1001}],
)
def test_reason_bad_input_is_4xx_with_a_message(base_url: str, body: dict) -> None:
    r = httpx.post(f"{base_url}/v1/reason", json=body)
    assert r.status_code == 422 and r.json()["detail"]


def test_reason_malformed_json(base_url: str) -> None:
    r = httpx.post(f"{base_url}/v1/reason", content=b"{nope", headers={"content-type": "application/json"})
    assert r.status_code == 422


def test_spec_from_image(base_url: str, tmp_path: Path) -> None:
    r = httpx.post(f"{base_url}/v1/spec", files={"image": ("a.png", _png(tmp_path), "image/png")}, timeout=60)
    assert r.status_code == 200, r.text
    spec = r.json()
    assert spec["caption"] == CAPTION.text and spec["is_dynamic"] is True
    assert spec["latency_ms"] >= CAPTION.latency_ms


@pytest.mark.parametrize(
    ("payload", "status"),
    [(b"", 400), (b"GIF89a....", 415), (b"\x89PNG\r\n\x1a\n" + b"\0" * 100, 400),
     (b"\xff\xd8\xff" + b"x" * 70_000, 413)],
)
def test_spec_rejects_bad_uploads(base_url: str, payload: bytes, status: int) -> None:
    r = httpx.post(f"{base_url}/v1/spec", files={"image": ("x", payload, "application/octet-stream")})
    assert r.status_code == status, r.text
    assert r.json()["detail"]


def test_spec_without_a_vle_is_503(engine: ReasonerEngine, tmp_path: Path) -> None:
    with _Server(create_app(engine, lambda _img: None, engine.settings)) as url:
        r = httpx.post(f"{url}/v1/spec", files={"image": ("a.png", _png(tmp_path), "image/png")})
    assert r.status_code == 503 and "llmland-vle" in r.json()["detail"]


def test_kb_read_write_validated_and_persisted(base_url: str, engine: ReasonerEngine) -> None:
    kb = httpx.get(f"{base_url}/v1/kb").json()
    entry = dict(kb["entries"][0])
    entry.update(id="llama_test", label="llama", synonyms=["alpaca"], description="a llama, a farm animal")
    r = httpx.post(f"{base_url}/v1/kb", json=entry, timeout=60)
    assert r.status_code == 201, r.text
    after = httpx.get(f"{base_url}/v1/kb").json()
    assert after["version"] != kb["version"] and any(e["id"] == "llama_test" for e in after["entries"])
    persisted = engine.settings.index_dir / "knowledge_base.json"
    assert "llama_test" in persisted.read_text()
    bad = dict(entry, buffer_m=-3)
    r = httpx.post(f"{base_url}/v1/kb", json=bad)
    assert r.status_code == 422 and "buffer_m" in r.text
    assert httpx.get(f"{base_url}/v1/kb").json()["version"] == after["version"]  # nothing written


def test_api_token(engine: ReasonerEngine) -> None:
    s = engine.settings.model_copy(update={"api_token": SecretStr("s3cret")})
    with _Server(create_app(engine, lambda _img: CAPTION, s)) as url:
        assert httpx.get(f"{url}/healthz").status_code == 200
        assert httpx.get(f"{url}/v1/kb").status_code == 401
        assert httpx.get(f"{url}/v1/kb", headers={"Authorization": "Bearer s3cret"}).status_code == 200


def test_fuzz_openapi_finds_no_server_errors(base_url: str) -> None:
    """Schemathesis cases from the served OpenAPI schema, every operation: never a 5xx."""
    schema = schemathesis.openapi.from_url(f"{base_url}/openapi.json")
    operations = [result.ok() for result in schema.get_all_operations()]
    assert {op.path for op in operations} >= {"/v1/reason", "/v1/spec", "/v1/kb", "/healthz"}
    for op in operations:

        @given(case=op.as_strategy())
        @settings(max_examples=15, deadline=None, suppress_health_check=list(HealthCheck), database=None)
        def check(case) -> None:  # type: ignore[no-untyped-def]
            response = case.call(base_url=base_url, timeout=60)
            detail = f"{case.method} {case.path}: {response.status_code} {response.text[:300]}"
            assert response.status_code < 500, detail

        check()
