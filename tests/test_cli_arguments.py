"""Bad command-line values are usage errors (exit 2, naming the option) before anything starts."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmland.cli import build_parser


@pytest.mark.parametrize(("argv", "says"), [
    (["land", "--seed", "-1"], "--seed: must be >= 0"),
    (["land", "--latency-model", "fixed:abc"], "--latency-model"),
    (["land", "--latency-model", "normal:1"], "--latency-model"),
    (["land", "--timeout", "nan"], "--timeout"),
    (["land", "--pedestrians", "-1"], "--pedestrians"),
    (["land", "--port", "99999"], "not a TCP port"),
    (["land", "--rrd", "/proc/nope/x.rrd"], "--rrd: cannot create"),
    (["experiment", "exp1", "--trials", "0", "--out", "{tmp}"], "--trials: must be >= 1"),
    (["experiment", "exp1", "--jobs", "0", "--out", "{tmp}"], "--jobs: must be >= 1"),
    (["experiment", "exp1", "--seed-base", "-5", "--out", "{tmp}"], "--seed-base"),
    (["experiment", "exp1", "--out", "/proc/nope/x"], "--out: cannot create"),
    (["experiment", "exp3", "--gguf", "/nonexistent.gguf", "--out", "{tmp}"], "no such file"),
    (["trials", "--seeds", "abc"], "not an integer"),
    (["ceiling", "--seeds", "5-1"], "is empty"),
    (["ceiling", "--worlds", "mars"], "unknown mars"),
    (["--log-level", "FOO", "land"], "--log-level"),
    (["land", "--kill", "planner@abc"], "not a number of seconds"),
    (["land", "--kill", "@5"], "SERVICE@SIM_S"),
    (["land", "--scenario", "walk-in:x"], "--scenario: 'walk-in:x': use walk-in:"),
    (["land", "--llm-model", "/nonexistent.gguf"], "--llm-model: no such file"),
    (["trials", "--seeds", "1", "--llm-model", "/nonexistent.gguf"], "--llm-model: no such file"),
    # were a traceback (drone id), a hang of up to 30 min (a folder for --rrd, killing the sim)
    (["land", "--drone-id", "a/b"], "--drone-id: invalid drone id"),
    (["up", "--drone-id", "x y"], "--drone-id: invalid drone id"),
    (["land", "--rrd", "{tmp}"], "is a folder"),
    (["land", "--kill", "sim@5"], "the sim is the episode"),
    # were tracebacks (a second newcomer): a file that is no model, a negative or zero fleet
    (["land", "--llm-model", "README.md"], "is no GGUF model file"),
    (["up", "--drones", "-2"], "--drones: must be >= 1"),  # said ">= 0" (a third newcomer)
    (["up", "--drones", "0"], "--drones: must be >= 1"),
    # a third newcomer: past the CLI, then refused by the schema or the OS (tracebacks), or unbounded
    (["land", "--timeout", "4000"], "--timeout: at most 3600 s"),
    (["experiment", "exp1", "--timeout", "4000", "--out", "{tmp}"], "--timeout: at most 3600 s"),
    (["mission", "--world", "open_field", "--seed", "1", "--wall-timeout", "-1"], "--wall-timeout: must be"),
    (["up", "--start-timeout", "nan"], "--start-timeout: must be"),
    (["up", "--log-dir", "{tmp}/file.txt"], "--log-dir: cannot create"),
    (["ceiling", "--seeds", "0-99999999999"], "more than 100000 seeds"),
    (["ceiling", "--seeds", "1-"], "ranges low-high"),
    (["ceiling", "--pedestrians", "300"], "at most 50 pedestrians"),
    (["up", "--drones", "1000"], "at most 32 drones"),
    # was silently ignored: `up --drones 2 --drone-id d3` started d0 and d1
    (["up", "--drones", "2", "--drone-id", "d3"], "not allowed with argument"),
    # a newcomer on the AMX Xeon: 100 stacks started on 2 cores; an empty time killed at 0 s;
    # an unknown service was a log line after argparse
    (["experiment", "exp1", "--jobs", "100", "--out", "{tmp}"], "--jobs: at most 16 jobs"),
    (["land", "--kill", "reasoner@"], "no time after '@'"),
    (["land", "--kill", "foo@3"], "'foo' is no service a fault run kills"),
])
def test_bad_values_are_usage_errors(argv: list[str], says: str, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "file.txt").write_text("a file, not a folder")
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args([a.replace("{tmp}", str(tmp_path)) for a in argv])
    assert exit_.value.code == 2
    assert says in capsys.readouterr().err


def test_bench_help_says_what_each_benchmark_measures(capsys: pytest.CaptureFixture[str]) -> None:
    from llmland.bench import BENCHMARKS

    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args(["bench", "--help"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out
    for name, what in BENCHMARKS.items():
        assert f"{name} " in out and what in out


def test_benchmark_figures_name_the_cpu(tmp_path: Path) -> None:
    """Figures differ by CPU (AVX-512, AMX): every benchmark's machine line names it."""
    from llmland.bench import _cpu, machine

    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nmodel name\t: Intel(R) Xeon(R) Processor\n"
                    "flags\t\t: fpu avx2 avx512f avx512bw amx_bf16 amx_tile amx_int8\n")
    assert _cpu(str(info)) == "Intel(R) Xeon(R) Processor (avx2, avx512f, amx_tile)"
    info.write_text("model name\t: AMD EPYC\nflags\t\t: fpu avx2 avx512f\n")
    assert _cpu(str(info)) == "AMD EPYC (avx2, avx512f)"
    assert set(machine()) == {"machine", "cpu"}


def test_good_values_parse() -> None:
    args = build_parser().parse_args(["ceiling", "--seeds", "1,4,7-9", "--worlds", "urban,open_field"])
    assert args.seeds == [1, 4, 7, 8, 9] and args.worlds == "urban,open_field"
    args = build_parser().parse_args(["--log-level", "debug", "land", "--latency-model", "normal:40,5"])
    assert args.log_level == "DEBUG" and args.latency_model == "normal:40,5" and args.seed == 1
    args = build_parser().parse_args(["land", "--scenario", "walk-in:5.5,1.5"])
    assert args.scenario == "walk-in:5.5,1.5"


def test_up_names_the_reasoners_http_address_from_its_settings(monkeypatch: pytest.MonkeyPatch) -> None:
    import llmland.cli as cli

    monkeypatch.setenv("LLMLAND_REASONER_HTTP_PORT", "9017")
    assert cli._reasoner_http_url() == "http://127.0.0.1:9017"


def test_killing_a_service_the_stack_does_not_run_is_refused_before_it_starts(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import llmland.cli as cli

    def no_stack(*_a: object, **_k: object) -> None:
        raise AssertionError("the stack was started")

    monkeypatch.setattr(cli, "open_stack", no_stack)
    args = build_parser().parse_args(["land", "--method", "baseline", "--kill", "reasoner@5"])
    assert args.kill == [("reasoner", 5.0)]
    assert cli.cmd_land(args) == 2


def test_checking_an_out_folder_creates_nothing(tmp_path: Path) -> None:
    out = tmp_path / "a" / "b"
    args = build_parser().parse_args(["experiment", "exp1", "--out", str(out)])
    assert args.out == str(out) and not (tmp_path / "a").exists() and list(tmp_path.iterdir()) == []


def test_a_taken_reasoner_http_port_stops_up_before_it_starts(monkeypatch: pytest.MonkeyPatch) -> None:
    """A second `up` beside a running stack printed the other stack's API address, then its reasoner
    could not bind and took the stack down; now it is refused first, naming the setting to change."""
    import socket

    import llmland.cli as cli
    from llmland.launch import StartupError

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        monkeypatch.setenv("LLMLAND_REASONER_HTTP_PORT", str(taken.getsockname()[1]))
        with pytest.raises(StartupError, match="LLMLAND_REASONER_HTTP_PORT"):
            cli._reasoner_http_port_free()


def test_bad_service_settings_are_one_line_each(monkeypatch: pytest.MonkeyPatch,
                                                caplog: pytest.LogCaptureFixture) -> None:
    from llmland_reasoner.settings import ReasonerSettings
    from llmland_schemas.service import BAD_SETTINGS_EXIT, settings_or_exit

    monkeypatch.setenv("LLMLAND_REASONER_HTTP_PORT", "abc")
    with pytest.raises(SystemExit) as exit_:
        settings_or_exit(ReasonerSettings)
    assert exit_.value.code == BAD_SETTINGS_EXIT
    assert "bad setting LLMLAND_REASONER_HTTP_PORT" in caplog.text and "Traceback" not in caplog.text



def _must_not_start(*_: object, **__: object) -> None:
    raise AssertionError("started work a usage check should have refused")


def test_a_fault_that_could_never_happen_is_refused_before_anything_starts(
        caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--kill reasoner@1e9`` was accepted and never fired: the episode ends first."""
    monkeypatch.setattr("llmland.cli.open_stack", _must_not_start)
    args = build_parser().parse_args(["land", "--kill", "reasoner@100"])
    assert args.func(args) == 2
    assert "at or after the episode's 90 s time limit" in caplog.text
    args = build_parser().parse_args(["land", "--specs", "oracle", "--kill", "vle@5"])
    assert args.func(args) == 2
    assert "this stack (method llm-land, --specs oracle) runs no vle" in caplog.text


@pytest.mark.parametrize(("argv", "says"), [
    (["exp1", "--worlds", "urban"], "exp1 is the paper's open-field experiment"),  # flew open_field silently
    (["exp3", "--methods", "baseline"], "exp3 compares LLM backends under llm-land"),
])
def test_experiments_refuse_options_they_would_ignore(argv: list[str], says: str, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    import llmland.experiment

    monkeypatch.setattr(llmland.experiment, "run_experiment", _must_not_start)
    args = build_parser().parse_args(["experiment", *argv, "--out", str(tmp_path)])
    with pytest.raises(SystemExit, match=says):
        args.func(args)


def test_the_summary_line_names_a_fault_run() -> None:
    from llmland_schemas import EpisodeResult

    from llmland.cli import summary_line

    r = EpisodeResult(drone_id="d0", stamp=30.0, seq=1500, episode_id="e", world="urban", seed=3, method="llm-land",
                      clock="lockstep", success=True, outcome="landed", touchdown_error_m=0.0, time_to_land_s=30.0,
                      min_person_distance_m={"person_0": 1.96}, close_calls=0, collisions=[], sim_time_s=30.0,
                      wall_time_s=12.0, perception_degraded=True, perception_degraded_s=25.0,
                      services_killed_at_s={"reasoner": 5.02})
    line = summary_line(r, 3.1, kills=[("reasoner", 5.0), ("planner", 50.0)])
    assert line.endswith("(after 3.1 s of service start-up); fault run: reasoner killed at 5.0 s; "
                         "fault run: planner@50 never fired")
    assert "fault run" not in summary_line(r)


def test_figures_print_nested_ones_one_line_each(capsys: pytest.CaptureFixture[str]) -> None:
    """``llmland ceiling`` without --json printed a world's figures as a raw Python dict."""
    from llmland.cli import _print_figures

    _print_figures({"timeout_s": 90.0, "urban": {"seeds": 3, "never_opens": [11]}}, as_json=False)
    lines = [line.split() for line in capsys.readouterr().out.splitlines()]
    assert lines == [["timeout_s", "90.0"], ["urban.seeds", "3"], ["urban.never_opens", "[11]"]]
