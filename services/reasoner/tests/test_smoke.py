"""The install's smoke check of the LLM runtime (``python -m llmland_reasoner.smoke``)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import llama_cpp
import pytest
from llmland_reasoner.smoke import (
    ALLOW_NATIVE_ENV,
    build_info,
    compiled_features,
    portability_problems,
    run_check,
)

# llama.cpp's own line for a native build on an AMX Xeon (Sapphire Rapids) and for ours
NATIVE_AMX = ("CPU : SSE3 = 1 | SSSE3 = 1 | AVX = 1 | AVX_VNNI = 1 | AVX2 = 1 | F16C = 1 | FMA = 1 | BMI2 = 1 | "
              "AVX512 = 1 | AVX512_VBMI = 1 | AVX512_VNNI = 1 | AVX512_BF16 = 1 | AMX_INT8 = 1 | LLAMAFILE = 1 | "
              "OPENMP = 1 | REPACK = 1 |")
PORTABLE = ("CPU : SSE3 = 1 | SSSE3 = 1 | AVX = 1 | AVX2 = 1 | F16C = 1 | FMA = 1 | BMI2 = 1 | LLAMAFILE = 1 | "
            "OPENMP = 1 |")


def test_features_are_read_from_the_system_info_line() -> None:
    assert compiled_features(PORTABLE) == {"SSE3", "SSSE3", "AVX", "AVX2", "F16C", "FMA", "BMI2", "LLAMAFILE",
                                           "OPENMP"}
    assert "AMX_INT8" in compiled_features(NATIVE_AMX)
    assert compiled_features("CPU : AVX512 = 0 | AMX_INT8 = 0 |") == set()


def test_an_amx_build_is_refused_and_an_avx512_build_reported() -> None:
    errors, warnings = portability_problems(compiled_features(NATIVE_AMX))
    assert len(errors) == 1 and "AMX_INT8" in errors[0]
    assert len(warnings) == 1 and "AVX512" in warnings[0] and "AMX_INT8" not in warnings[0]
    assert portability_problems(compiled_features(PORTABLE)) == ([], [])


@pytest.mark.skipif(os.environ.get(ALLOW_NATIVE_ENV) == "1", reason="a build for this machine, on purpose")
def test_the_installed_runtime_is_the_portable_build() -> None:
    """The runtime this suite runs on has no AMX or AVX-512 code path compiled in: the build of
    ``scripts/build_llama.sh``, not a native wheel from pip's cache (which would crash on AMX Xeons)."""
    info = llama_cpp.llama_print_system_info().decode(errors="replace")
    assert portability_problems(compiled_features(info)) == ([], []), info
    assert "GGML_NATIVE=OFF" in str(build_info().get("cmake_args")), build_info()


def test_the_check_evaluates_the_default_model_in_a_child_process() -> None:
    result = run_check(timeout_s=60.0)
    assert result["tokens"] > 3 and result["eval_ms"] > 0.0
    assert compiled_features(result["system_info"]) == compiled_features(
        llama_cpp.llama_print_system_info().decode(errors="replace"))


def test_a_model_that_cannot_be_evaluated_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "broken.gguf"
    bad.write_bytes(b"GGUF" + b"\0" * 64)
    with pytest.raises(RuntimeError, match=r"could not evaluate the model \(cannot load .*broken.gguf"):
        run_check(str(bad), timeout_s=60.0)


def test_a_runtime_that_segfaults_is_a_clear_error_not_a_traceback(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    # the child's work dies the way the native AMX build does (SIGSEGV at the first evaluation); it
    # lives in a module of its own that the spawned child imports (spawn passes sys.path on)
    (tmp_path / "segfaulting_runtime.py").write_text(
        "import os, signal\n\ndef evaluate(model_path, out):\n    os.kill(os.getpid(), signal.SIGSEGV)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import segfaulting_runtime

    with pytest.raises(RuntimeError, match="killed by signal 11.*scripts/build_llama.sh"):
        run_check(timeout_s=60.0, evaluate=segfaulting_runtime.evaluate)


def test_the_command_fails_with_a_message_and_a_non_zero_exit(tmp_path: Path) -> None:
    bad = tmp_path / "broken.gguf"
    bad.write_bytes(b"not a model")
    done = subprocess.run([sys.executable, "-m", "llmland_reasoner.smoke", str(bad)], capture_output=True,
                          text=True, timeout=120, env={ALLOW_NATIVE_ENV: "0", "PATH": ""})
    assert done.returncode == 1
    assert "LLM smoke check FAILED" in done.stderr
