"""The HTTP API against a real uvicorn server on a loopback port."""

from __future__ import annotations

import socket
import struct
import threading
import time
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import schemathesis
import uvicorn
from fastapi import FastAPI, HTTPException
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from llmland_reasoner.engine import ReasonerEngine
from llmland_reasoner.http_api import create_app
from llmland_reasoner.kb import KbEntryExistsError, add_to_additions, read_additions
from llmland_reasoner.resources import Resources
from llmland_reasoner.settings import ReasonerSettings
from llmland_reasoner.upload import check_image, image_size
from llmland_schemas import Caption
from PIL import Image
from pydantic import SecretStr
from schemathesis import APIOperation, GenerationMode
from schemathesis.core.errors import InvalidSchema
from schemathesis.core.result import Err, Ok

CAPTION = Caption(text="a person walking on a grass field", backend="test", latency_ms=12.0)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _Server:
    def __init__(self, app: FastAPI) -> None:
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


@pytest.mark.parametrize(
    "body",
    [b'{"caption": "a man \\ud800 walking"}', b'{"caption": "a man \\udfff"}', b'{"caption": "a \xff\xfe man"}',
     b"\xff\xd8\xff\xe0garbage", b'{"caption": "\\ud83d"}'],
)
def test_reason_refuses_bodies_that_are_not_unicode_json_with_422(base_url: str, body: bytes) -> None:
    """Lone surrogates and undecodable bytes (a 500 before: the error handler could not encode them)."""
    r = httpx.post(f"{base_url}/v1/reason", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 422, r.text
    assert r.json()["detail"]


def test_oversized_json_is_413_before_parsing(base_url: str) -> None:
    body = b'{"caption": "' + b"a" * 200_000 + b'"}'
    r = httpx.post(f"{base_url}/v1/reason", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 413 and r.json()["detail"]


def test_kb_write_with_a_surrogate_is_422(base_url: str) -> None:
    body = b'{"id": "x", "label": "\\ud800", "category": "structure", "is_dynamic": false, "is_human": false,' \
           b' "z_min": 1, "buffer_m": 1, "description": "x"}'
    r = httpx.post(f"{base_url}/v1/kb", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["detail"]


def test_reason_refuses_images_and_forms_with_415(base_url: str, tmp_path: Path) -> None:
    """A multipart form or a raw PNG sent to the caption route (a 500 before)."""
    png = _png(tmp_path)
    r = httpx.post(f"{base_url}/v1/reason", files={"image": ("a.png", png, "image/png")})
    assert r.status_code == 415 and "multipart/form-data" in r.json()["detail"]
    r = httpx.post(f"{base_url}/v1/reason", content=png, headers={"content-type": "image/png"})
    assert r.status_code == 415
    r = httpx.post(f"{base_url}/v1/reason", content=png, headers={"content-type": "application/json"})
    assert r.status_code == 422


def _png_claiming(width: int, height: int, tmp: Path) -> bytes:
    """A small valid PNG whose IHDR claims ``width`` x ``height`` pixels (CRC fixed)."""
    data = bytearray(_png(tmp, 8))
    data[16:24] = struct.pack(">II", width, height)
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])))
    return bytes(data)


def _jpeg_claiming(width: int, height: int) -> bytes:
    app0 = b"\xff\xe0" + struct.pack(">H", 16) + b"JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00"
    sof0 = b"\xff\xc0" + struct.pack(">HBHHB", 11, 8, height, width, 1) + b"\x01\x11\x00"
    return b"\xff\xd8" + app0 + sof0 + b"\xff\xd9"


@pytest.mark.parametrize("side", [5000, 15000, 30000])
def test_spec_refuses_too_many_pixels_from_the_header_with_413(base_url: str, tmp_path: Path, side: int) -> None:
    """15000^2 and 30000^2 were 500s (Pillow's DecompressionBombError inside Image.open)."""
    for data in (_png_claiming(side, side, tmp_path), _jpeg_claiming(side, side)):
        assert image_size(data) == (side, side)
        r = httpx.post(f"{base_url}/v1/spec", files={"image": ("x", data, "application/octet-stream")})
        assert r.status_code == 413 and "too large" in r.json()["detail"], r.text


def test_a_real_decompression_bomb_is_413(base_url: str, tmp_path: Path) -> None:
    path = tmp_path / "bomb.png"
    Image.new("1", (20_000, 20_000)).save(path, optimize=True)  # 400 Mpx of zeros in a few tens of kB
    data = path.read_bytes()
    assert len(data) < 64 * 1024
    r = httpx.post(f"{base_url}/v1/spec", files={"image": ("bomb.png", data, "image/png")})
    assert r.status_code == 413, r.text


def test_pillows_own_bomb_check_is_caught_too(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Second line: an image the header check lets through but Pillow refuses is a 413, not a 500."""
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 10)
    with pytest.raises(HTTPException) as err:
        check_image(_png(tmp_path, 32), max_bytes=1 << 20)
    assert err.value.status_code == 413


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
    persisted = engine.settings.index_dir / "kb_additions.json"  # the entry, apart from the shipped KB
    assert [e.id for e in read_additions(persisted)] == ["llama_test"]
    bad = dict(entry, buffer_m=-3)
    r = httpx.post(f"{base_url}/v1/kb", json=bad)
    assert r.status_code == 422 and "buffer_m" in r.text
    for unsafe, reason in (({"category": "person", "is_human": False, "is_dynamic": False, "buffer_m": 0.0},
                            "is_human true"),
                           ({"id": "dog", "label": "dog", "category": "animal", "is_dynamic": False, "buffer_m": 0.0},
                            "is_dynamic must be true")):
        r = httpx.post(f"{base_url}/v1/kb", json=dict(entry, **unsafe))
        assert r.status_code == 422 and reason in r.json()["detail"], r.text
    assert httpx.get(f"{base_url}/v1/kb").json()["version"] == after["version"]  # nothing written


def test_api_token(engine: ReasonerEngine) -> None:
    s = engine.settings.model_copy(update={"api_token": SecretStr("s3cret")})
    with _Server(create_app(engine, lambda _img: CAPTION, s)) as url:
        assert httpx.get(f"{url}/healthz").status_code == 200
        assert httpx.get(f"{url}/v1/kb").status_code == 401
        assert httpx.get(f"{url}/v1/kb", headers={"Authorization": "Bearer s3cret"}).status_code == 200


def _png_without_image_data() -> bytes:
    """A PNG with its header and end chunks but no IDAT: Pillow's verify() raised IndexError (a 500)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 4, 4, 8, 2, 0, 0, 0)) + chunk(b"IEND", b"")


def test_inputs_that_were_500s_are_4xx(base_url: str, engine: ReasonerEngine) -> None:
    r = httpx.post(f"{base_url}/v1/spec", files={"image": ("x.png", _png_without_image_data(), "image/png")})
    assert r.status_code == 400 and "corrupt image" in r.json()["detail"], r.text
    big = b'{"caption": "a dog", "mode": ' + b"9" * 5000 + b"}"  # past Python's 4300-digit int limit
    for route in ("/v1/reason", "/v1/kb"):
        r = httpx.post(f"{base_url}{route}", content=big, headers={"content-type": "application/json"})
        assert r.status_code == 422 and "not valid JSON" in r.json()["detail"], r.text
    s = engine.settings.model_copy(update={"api_token": SecretStr("s3cret")})
    with _Server(create_app(engine, lambda _img: CAPTION, s)) as url:
        for header in (b"Bearer caf\xe9", b"Bearer \xff\xfe"):
            assert httpx.get(f"{url}/v1/kb", headers={b"Authorization": header}).status_code == 401
        assert httpx.get(f"{url}/v1/kb", headers={"Authorization": "bearer s3cret"}).status_code == 200


def test_an_image_the_vle_refuses_is_422_with_its_message(engine: ReasonerEngine, tmp_path: Path) -> None:
    from llmland_reasoner.upload import CaptionFailedError, CaptionRefusedError

    def refuse(_img: bytes) -> Caption | None:
        raise CaptionRefusedError("image of 1x1 px is outside 8..4096 px a side")

    def fail(_img: bytes) -> Caption | None:
        raise CaptionFailedError("captioning failed: out of memory")

    with _Server(create_app(engine, refuse, engine.settings)) as url:
        r = httpx.post(f"{url}/v1/spec", files={"image": ("a.png", _png(tmp_path, size=1), "image/png")})
    assert r.status_code == 422 and "1x1 px" in r.json()["detail"], r.text
    with _Server(create_app(engine, fail, engine.settings)) as url:  # the VLE's own failure is not the image's
        r = httpx.post(f"{url}/v1/spec", files={"image": ("a.png", _png(tmp_path), "image/png")})
    assert r.status_code == 502 and "out of memory" in r.json()["detail"], r.text


def test_a_slow_vle_does_not_hold_other_requests(engine: ReasonerEngine, tmp_path: Path) -> None:
    """/v1/spec waited on the VLE on the event loop: /healthz took as long as the VLE's timeout."""
    release = threading.Event()

    def slow(_img: bytes) -> Caption | None:
        release.wait(10.0)
        return CAPTION

    with _Server(create_app(engine, slow, engine.settings)) as url:
        png = _png(tmp_path)
        pending = threading.Thread(target=lambda: httpx.post(f"{url}/v1/spec", timeout=20,
                                                             files={"image": ("a.png", png, "image/png")}))
        pending.start()
        time.sleep(0.3)
        started = time.monotonic()
        assert httpx.get(f"{url}/healthz", timeout=20).status_code == 200
        waited = time.monotonic() - started
        release.set()
        pending.join(20)
    assert waited < 2.0


def test_the_api_does_not_replace_an_existing_kb_entry(base_url: str) -> None:
    """A write replacing "pedestrian" with a bench passed every category rule and removed the person."""
    kb = httpx.get(f"{base_url}/v1/kb").json()
    person = next(e for e in kb["entries"] if e["is_human"])
    bench = dict(person, label="bench", category="structure", is_dynamic=False, is_human=False, buffer_m=1.0)
    r = httpx.post(f"{base_url}/v1/kb", json=bench)
    assert r.status_code == 409 and "exists" in r.json()["detail"], r.text
    assert httpx.get(f"{base_url}/v1/kb").json()["version"] == kb["version"]


def test_concurrent_posts_of_one_new_id_add_it_once(base_url: str, engine: ReasonerEngine,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The route checked "exists" before the (serialised) write: concurrent POSTs of one new id all
    passed the check and each later write replaced the one before it. The KB's writer is slowed (as
    a busy worker would) so that the requests surely overlap a write."""
    kb_add = engine.resources.kb.add

    def slow_add(entry: Any, **kwargs: Any) -> Any:
        time.sleep(0.5)
        return kb_add(entry, **kwargs)

    monkeypatch.setattr(engine.resources.kb, "add", slow_add)
    kb = httpx.get(f"{base_url}/v1/kb").json()
    entry = dict(next(e for e in kb["entries"] if not e["is_human"] and not e["is_dynamic"]),
                 id="race_test_shed", label="race test shed", synonyms=[], description="a garden shed")
    codes: list[int] = []
    ready = threading.Barrier(4)

    def post(z_min: float) -> None:
        ready.wait()
        codes.append(httpx.post(f"{base_url}/v1/kb", json=dict(entry, z_min=z_min), timeout=60).status_code)

    threads = [threading.Thread(target=post, args=(0.5 + k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert sorted(codes) == [201, 409, 409, 409], codes
    after = httpx.get(f"{base_url}/v1/kb").json()
    assert int(after["version"].split(".")[2]) == int(kb["version"].split(".")[2]) + 1  # one write


def _operation(result: Ok[APIOperation[Any, Any, Any, Any]] | Err[InvalidSchema]) -> APIOperation[Any, Any, Any, Any]:
    """The operation a schema result holds; an invalid one fails the test with its error."""
    if isinstance(result, Err):
        raise result.err()
    return result.ok()


@pytest.mark.parametrize("mode", [GenerationMode.POSITIVE, GenerationMode.NEGATIVE])
def test_fuzz_openapi_finds_no_server_errors(base_url: str, mode: GenerationMode) -> None:
    """Schemathesis cases from the served OpenAPI schema, every operation, valid and invalid
    (negative mode: bodies that break the schema): never a 5xx."""
    schema = schemathesis.openapi.from_url(f"{base_url}/openapi.json")
    operations = [_operation(result) for result in schema.get_all_operations()]
    assert {op.path for op in operations} >= {"/v1/reason", "/v1/spec", "/v1/kb", "/healthz"}
    for op in operations:
        if mode == GenerationMode.NEGATIVE and op.method.upper() != "POST":
            continue  # nothing to break in a GET without parameters

        @given(case=op.as_strategy(generation_mode=mode))
        @settings(max_examples=15, deadline=None, suppress_health_check=list(HealthCheck), database=None)
        def check(case) -> None:  # type: ignore[no-untyped-def]
            response = case.call(base_url=base_url, timeout=60)
            detail = f"{case.method} {case.path}: {response.status_code} {response.text[:300]}"
            assert response.status_code < 500, detail

        check()


_JSON_PIECES = st.sampled_from(["\\ud800", "\\udfff", "\\u0000", '\\"', "\\\\", '"', "{", "}", "[", ",", ":",
                                "\\x", "caption", "mode", "rag", "null", "1e999"])
_MALFORMED_JSON = st.lists(st.one_of(_JSON_PIECES, st.text(max_size=6)), max_size=12).map(
    lambda parts: ('{"caption": "' + "".join(parts)).encode("utf-8", "surrogatepass"))
_CONTENT_TYPES = st.sampled_from(["application/json", "multipart/form-data; boundary=x", "image/png", "text/plain",
                                  "application/octet-stream", "application/x-www-form-urlencoded", ""])


def test_fuzz_binary_and_malformed_bodies_find_no_server_errors(base_url: str) -> None:
    """Beyond the schema: random bytes and broken JSON under every content type, on every POST route."""

    @given(path=st.sampled_from(["/v1/reason", "/v1/kb", "/v1/spec"]), ctype=_CONTENT_TYPES,
           body=st.one_of(st.binary(max_size=512), _MALFORMED_JSON))
    @settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    def check(path: str, ctype: str, body: bytes) -> None:
        headers = {"content-type": ctype} if ctype else {}
        response = httpx.post(f"{base_url}{path}", content=body, headers=headers, timeout=60)
        assert response.status_code < 500, f"{path} {ctype} {body[:80]!r}: {response.status_code} {response.text[:200]}"
        response.json()  # always a JSON error body

    check()


def test_an_id_the_additions_file_holds_is_no_new_entry_even_unloaded(engine: ReasonerEngine) -> None:
    """A reasoner started with KB_ADDITIONS=false (every `llmland land`/`experiment` one) does not
    hold the file's entries, but a write of one of their ids is still refused (review: it silently
    replaced the recorded entry)."""
    path = engine.settings.kb_additions_path
    shipped = engine.extractor().resources.kb.get("pedestrian")
    recorded = shipped.model_copy(update={"id": "only_in_the_file", "label": "only in the file"})
    add_to_additions(path, recorded)  # another process's write, or one from before a restart
    with pytest.raises(KbEntryExistsError):
        engine.add_entry(recorded.model_copy(update={"buffer_m": 9.0}), replace=False)
    assert [e.buffer_m for e in read_additions(path) if e.id == "only_in_the_file"] == [recorded.buffer_m]
