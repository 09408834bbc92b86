"""``llmland``: launch the services, fly episodes, run benchmarks (docs/DESIGN.md §13)."""

from __future__ import annotations

import argparse
import faulthandler
import json
import logging
import os
import signal
import socket
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from urllib.parse import urlsplit

from llmland_schemas import EpisodeResult, MissionGoal
from llmland_schemas.bus import DEFAULT_ENDPOINT
from llmland_schemas.messages import METHOD_NAMES, WORLD_NAMES
from llmland_schemas.service import configure_logging, settings_or_exit, shutdown_event

from .arguments import (
    drone_count,
    drone_id,
    episode_seconds,
    fault,
    gguf_file,
    job_count,
    latency_model,
    names_from,
    non_negative_int,
    pedestrian_count,
    port,
    positive_int,
    positive_seconds,
    scenario,
    seed_list,
    writable_dir,
    writable_file,
)
from .launch import (
    SERVICE_MODULES,
    Fleet,
    SpecsServed,
    StartupError,
    drone_ids,
    hub_bus,
    hub_endpoint,
    raise_keyboard_interrupt,
)
from .results import summarize
from .stacks import StackConfig, make_mission, open_stack
from .view import add_view_parser

log = logging.getLogger("llmland")

WORLDS = list(WORLD_NAMES)
LOG_LEVELS = ["DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL"]
METHODS = list(METHOD_NAMES)
#: how often `llmland up` logs the reasoner's specs per drone (s), when they changed
SERVED_LOG_PERIOD_S = 30.0


def _config(args: argparse.Namespace) -> StackConfig:
    return StackConfig(method=args.method, specs=args.specs, llm_model_path=args.llm_model)


def _mission(args: argparse.Namespace, cfg: StackConfig, seed: int, rrd: str | None = None) -> MissionGoal:
    return make_mission(cfg, world=args.world, seed=seed, timeout_s=args.timeout, drone_id=args.drone_id,
                        clock=args.clock, n_pedestrians=args.pedestrians, latency_model=args.latency_model, rrd=rrd,
                        scenario=args.scenario)


def summary_line(r: EpisodeResult, startup_s: float | None = None, kills: Sequence[tuple[str, float]] = ()) -> str:
    """One human-readable line: outcome, touchdown error, closest person, spec latency, wall time
    (and the services' start-up before it, ``startup_s``, when given); last, a fault run's kills
    (``kills``: service, sim s asked) with the sim time (s) each service died at (the result's
    ``services_killed_at_s``), or that it never fired (the episode ended first)."""
    killed_at_s = r.services_killed_at_s
    td = f"{r.touchdown_error_m:.2f} m" if r.touchdown_error_m is not None else "—"
    closest = f"{min(r.min_person_distance_m.values()):.2f} m" if r.min_person_distance_m else "no person"
    lat = f"{r.spec_latency_ms_mean:.0f} ms" if r.spec_latency_ms_mean is not None else "—"
    degraded = f", perception degraded {r.perception_degraded_s:.1f} s" if r.perception_degraded else ""
    return (f"{r.method} {r.world} seed {r.seed}: {r.outcome.upper()} — touchdown error {td}, "
            f"closest person {closest}, spec latency {lat}, {r.sim_time_s:.1f} s flown in "
            f"{r.wall_time_s:.1f} s wall{degraded}"
            + (f" (after {startup_s:.1f} s of service start-up)" if startup_s is not None else "")
            + "".join(f"; fault run: {name} killed at {killed_at_s[name]:.1f} s"
                      if name in killed_at_s else f"; fault run: {name}@{at:g} never fired"
                      for name, at in kills))


def cmd_land(args: argparse.Namespace) -> int:
    rrd = str(Path(args.rrd).resolve()) if args.rrd else None
    cfg = _config(args)
    absent = [service for service, _ in args.kill if service not in cfg.services()]
    if absent:
        log.error("--kill %s: this stack (method %s, --specs %s) runs no %s; it runs %s", ", ".join(absent),
                  args.method, args.specs, ", ".join(absent), ", ".join(cfg.services()))
        return 2
    late = [f"{service}@{at:g}" for service, at in args.kill if at >= args.timeout]
    if late:
        log.error("--kill %s: at or after the episode's %g s time limit (--timeout): it would never happen",
                  ", ".join(late), args.timeout)
        return 2
    t0 = time.perf_counter()
    with open_stack(cfg, drone_id=args.drone_id, port=args.port, log_level=args.service_log_level) as running:
        startup_s = time.perf_counter() - t0
        for service, at in args.kill:
            running.kill_at(service, at)
        try:
            result = running.run(_mission(args, cfg, args.seed, rrd))
        except (RuntimeError, TimeoutError) as exc:  # the sim died, or no result in the wall limit
            log.error("%s", exc)
            return 1
    sys.stderr.write(summary_line(result, startup_s, args.kill) + "\n")
    sys.stderr.flush()
    sys.stdout.write(result.model_dump_json(indent=2) + "\n")
    return 0 if result.success or not args.strict else 1


def cmd_trials(args: argparse.Namespace) -> int:
    """Many seeds on one running stack; a CSV row per episode as it ends (the columns of
    ``llmland experiment``'s trials.csv) and a summary."""
    from .experiment.plan import Trial
    from .experiment.runner import append_row, trial_row

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "trials.csv"
    csv_path.unlink(missing_ok=True)
    rows: list[EpisodeResult] = []
    cfg = _config(args)
    with open_stack(cfg, drone_id=args.drone_id, port=args.port, log_level=args.service_log_level) as running:
        for seed in args.seeds:
            try:
                r = running.run(_mission(args, cfg, seed))
            except (RuntimeError, TimeoutError) as exc:  # the sim died, or no result in the wall limit
                log.error("seed %d: %s; the %d rows before it are in %s", seed, exc, len(rows), csv_path)
                return 1
            rows.append(r)
            append_row(csv_path, trial_row(Trial(args.world, args.method, seed, latency_model=args.latency_model),
                                           r, None))
            log.info("%s", summary_line(r))
    summary = summarize(rows)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    sys.stdout.write(json.dumps(summary, indent=2) + "\n")
    return 0


def _csv(text: str | None) -> list[str] | None:
    return [x.strip() for x in text.split(",") if x.strip()] if text else None


def cmd_experiment(args: argparse.Namespace) -> int:
    """One of the paper's experiments into ``--out``: trials.csv, summary.json, results.md, plots."""
    from .bench import machine
    from .experiment import run_experiment

    methods, worlds = _csv(args.methods), _csv(args.worlds)
    for m in methods or []:
        if m not in METHODS:
            raise SystemExit(f"llmland experiment: unknown method {m!r}; choose from {', '.join(METHODS)}")
    for w in worlds or []:
        if w not in WORLDS:
            raise SystemExit(f"llmland experiment: unknown world {w!r}; choose from {', '.join(WORLDS)}")
    if args.experiment == "exp1" and worlds and worlds != ["open_field"]:  # was silently ignored
        raise SystemExit("llmland experiment: exp1 is the paper's open-field experiment; --worlds is for "
                         "exp2 (the three worlds) and exp3")
    if args.experiment == "exp3" and methods and methods != ["llm-land"]:  # was silently ignored
        raise SystemExit("llmland experiment: exp3 compares LLM backends under llm-land; --methods is for exp1 "
                         "and exp2 (other models: --gguf)")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if args.jobs > cores:
        log.warning("--jobs %d on %d cores: the episodes share the cores (each lockstep episode keeps about one "
                    "busy): no faster, and with the measured latency model slower perception changes the "
                    "episodes themselves", args.jobs, cores)
    try:
        summary = run_experiment(
            args.experiment, Path(args.out), trials=args.trials, seed_base=args.seed_base, methods=methods,
            worlds=worlds, latency_model=args.latency_model, specs=args.specs,
            ggufs=[Path(g).resolve() for g in args.gguf], jobs=args.jobs, timeout_s=args.timeout, rrd=args.rrd,
            resume=args.resume, overwrite=args.overwrite, log_level=args.service_log_level,
            machine="{machine}; {cpu}".format(**machine()))
    except ValueError as exc:  # a --resume that would mix two ways of flying, an earlier run in OUT
        raise SystemExit(f"llmland experiment: {exc}") from exc
    sys.stdout.write(json.dumps(summary, indent=2) + "\n")
    errored, missing = summary["errored_trials"], summary["missing_trials"]
    if errored or missing:
        log.error("incomplete: %d trial(s) errored (%s), %d never ran (%s); `--resume` flies them again",
                  len(errored), ", ".join(errored) or "none", len(missing), ", ".join(missing) or "none")
        return 1
    return 0


def cmd_up(args: argparse.Namespace) -> int:
    """Start the services (``--drones N``: sim+planner+VLE per drone d0…, one reasoner) until Ctrl-C."""
    stop = shutdown_event()
    port = args.port
    drones = drone_ids(args.drones) if args.drones else [args.drone_id]
    log_dir = Path(args.log_dir) if args.log_dir else None
    api_url = _reasoner_http_port_free() if "reasoner" in args.services else None
    with hub_bus(port) as bus, Fleet(port, drones, log_level=args.service_log_level, log_dir=log_dir) as fleet:
        fleet.start(args.services)
        fleet.wait_alive(bus, timeout_s=args.start_timeout, interrupted=stop)
        flies = {"sim", "planner"} <= set(args.services) or {"sim", "pilot"} <= set(args.services)
        hint = (f"send a mission with `llmland mission --world open_field --seed 1 --drone-id {drones[0]} "
                f"--connect {hub_endpoint(port)}`"
                if flies else "no sim with a planner or pilot here: missions need them (on this bus or another)")
        log.info("services up on %s for drone(s) %s: %s — %s; Ctrl-C stops all", hub_endpoint(port),
                 ", ".join(drones), ", ".join(args.services), hint)
        if "reasoner" in args.services:
            log.info("reasoner HTTP API on %s (POST an image to /v1/spec; OpenAPI schema at /openapi.json, "
                     "Swagger UI at /docs, its scripts from a CDN)", api_url)
        served, next_log = SpecsServed(bus), time.monotonic() + SERVED_LOG_PERIOD_S
        logged: dict[str, int] = {}
        while not stop.wait(0.5):
            for name, proc in fleet.procs().items():
                if proc.poll() is not None:
                    log.error("%s exited with code %s", name, proc.returncode)
                    return 1
            if time.monotonic() >= next_log and (counts := served.counts()) != logged:
                log.info("reasoner specs served per drone: %s", counts)
                logged, next_log = counts, time.monotonic() + SERVED_LOG_PERIOD_S
        log.info("stopping; reasoner specs served per drone: %s", served.counts())
    return 0


def _reasoner_http_url() -> str:
    """Where the reasoner started by ``up`` serves HTTP: its own settings, from the same environment."""
    from llmland_reasoner.settings import ReasonerSettings

    settings = settings_or_exit(ReasonerSettings)
    return f"http://{settings.http_host}:{settings.http_port}"


def _reasoner_http_port_free() -> str:
    """The reasoner's HTTP address (as :func:`_reasoner_http_url`), or :class:`StartupError` when its
    port is taken (another stack's reasoner: it would exit at once and take this stack down, after
    ``up`` had printed the other one's address)."""
    url = _reasoner_http_url()
    address = urlsplit(url)
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn binds: TIME_WAIT is no owner
        try:
            probe.bind((address.hostname, address.port))
        except OSError as exc:
            raise StartupError(f"the reasoner's HTTP port {address.netloc} is taken "
                               f"({exc.strerror}): another stack? Give this one LLMLAND_REASONER_HTTP_PORT=<free port> "
                               "(and --port)") from None
    return url


def cmd_mission(args: argparse.Namespace) -> int:
    """Send one mission to a running stack; print its EpisodeResult JSON (like ``land``)."""
    from .mission import MissionError, MissionRequest, send_mission

    req = MissionRequest(world=args.world, seed=args.seed, method=args.method, drone_id=args.drone_id,
                         timeout_s=args.timeout, clock=args.clock, n_pedestrians=args.pedestrians,
                         wall_timeout_s=args.wall_timeout)
    try:
        result = send_mission(req, _csv(args.connect) or [])
    except MissionError as exc:
        log.error("%s", exc)
        return exc.exit_code
    except ValueError as exc:
        log.error("%s", exc)
        return 2
    sys.stderr.write(summary_line(result) + "\n")
    sys.stderr.flush()
    sys.stdout.write(result.model_dump_json(indent=2) + "\n")
    return 0 if result.success or not args.strict else 1


@contextmanager
def _stdout_to_stderr() -> Iterator[None]:
    sys.stdout.flush()
    saved = os.dup(1)
    os.dup2(2, 1)
    try:
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def cmd_bench(args: argparse.Namespace) -> int:
    from . import bench

    with _stdout_to_stderr():  # C libraries (EGL, pybullet) print to fd 1: keep the JSON clean
        figures = bench.run(args.what, quick=args.quick)
    _print_figures(figures, as_json=args.json)
    return 0


def _print_figures(figures: Mapping[str, object], *, as_json: bool) -> None:
    """A flat mapping to stdout: JSON, or one ``name value`` line each."""
    if as_json:
        sys.stdout.write(json.dumps(figures, indent=2) + "\n")
    else:
        for k, v in _flat(figures):
            sys.stdout.write(f"{k:40s} {v}\n")


def _flat(figures: Mapping[str, object], prefix: str = "") -> Iterator[tuple[str, object]]:
    """``(name, value)`` pairs, nested mappings as ``outer.inner`` names (one line each)."""
    for k, v in figures.items():
        if isinstance(v, Mapping):
            yield from _flat(v, f"{prefix}{k}.")
        else:
            yield f"{prefix}{k}", v


def _episode_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--world", choices=WORLDS, default="open_field", help="(default: open_field)")
    p.add_argument("--method", choices=METHODS, default="llm-land",
                   help="llm-land (RAG, the default), llm (no retrieval), baseline (geometry, 1 m margin), "
                        "conservative (geometry, every obstacle a person), reference (no obstacles)")
    p.add_argument("--clock", choices=["lockstep", "realtime"], default="lockstep",
                   help="lockstep (default: latency-faithful, faster than real time) or realtime")
    p.add_argument("--timeout", type=episode_seconds, default=90.0,
                   help="episode time limit (sim seconds; default 90)")
    p.add_argument("--pedestrians", type=pedestrian_count, default=None,
                   help="number of pedestrians (default: the world's)")
    p.add_argument("--specs", choices=["pipeline", "oracle", "none"], default="pipeline",
                   help="semantic methods: where specs come from — pipeline (VLE captions → reasoner), "
                        "oracle (given from ground truth), none")
    p.add_argument("--latency-model", type=latency_model, default=None,
                   help="lockstep: when specs take effect — measured (default for the pipeline), fixed:<ms>, "
                        "normal:<mean_ms>,<sd_ms> (fixed:50 for oracle specs)")
    p.add_argument("--llm-model", type=gguf_file, default=None,
                   help="a GGUF file for the reasoner (default: SmolLM2-135M)")
    p.add_argument("--scenario", type=scenario, default=None,
                   help="scripted test: walk-in:<distance_m>,<speed_mps> (a person walks to the pad as the "
                        "final descent starts)")
    p.add_argument("--drone-id", type=drone_id, default="d0", help="(default: d0)")
    p.add_argument("--port", type=port, default=0, help="bus port (default: a free one)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="llmland", description=__doc__)
    parser.add_argument("--log-level", type=str.upper, choices=LOG_LEVELS, default="INFO")
    parser.add_argument("--service-log-level", type=str.upper, choices=LOG_LEVELS, default="WARNING",
                        help="log level of the child services")
    sub = parser.add_subparsers(dest="command", required=True)
    _add_land_parser(sub)
    _add_trials_parser(sub)
    _add_experiment_parser(sub)
    _add_up_parser(sub)
    _add_mission_parser(sub)
    _add_bench_parser(sub)
    _add_ceiling_parser(sub)
    add_view_parser(sub)
    return parser


def _add_land_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    land = sub.add_parser("land", help="fly one episode and print its EpisodeResult JSON")
    _episode_args(land)
    land.add_argument("--seed", type=non_negative_int, default=1, help="the world's seed (default: 1)")
    land.add_argument("--rrd", type=writable_file, help="write a Rerun recording of the episode to this file")
    land.add_argument("--strict", action="store_true", help="exit 1 unless the landing succeeded")
    land.add_argument("--kill", type=fault, action="append", default=[], metavar="SERVICE@SIM_S",
                      help="fault run: kill a service (vle, reasoner, planner) when the episode reaches SIM_S "
                           "seconds (SERVICE alone: at 0 s)")
    land.set_defaults(func=cmd_land)


def _add_trials_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    trials = sub.add_parser("trials", help="fly many seeds on one stack; CSV + summary")
    _episode_args(trials)
    trials.add_argument("--seeds", type=seed_list, default="1-20", help="e.g. 1-20 or 1,4,7-9")
    trials.add_argument("--out", type=writable_dir, default="runs/trials")
    trials.set_defaults(func=cmd_trials)


def _add_experiment_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    exp = sub.add_parser("experiment", help="run exp1|exp2|exp3 (docs/DESIGN.md §8) into a results folder")
    exp.add_argument("experiment", choices=["exp1", "exp2", "exp3"])
    exp.add_argument("--trials", type=positive_int, default=50, help="trials per row (default 50)")
    exp.add_argument("--seed-base", type=non_negative_int, default=1, help="trial i flies seed S+i")
    exp.add_argument("--methods", type=names_from(METHODS),
                     help=f"comma-separated, default all of: {', '.join(METHODS[1:])}")
    exp.add_argument("--worlds", type=names_from(WORLDS),
                     help=f"comma-separated (exp2 and exp3; exp1 is open_field), default all of: "
                          f"{', '.join(WORLDS)} (exp3: open_field)")
    exp.add_argument("--latency-model", type=latency_model, default=None,
                     help="measured (default), fixed:<ms> or normal:<mean_ms>,<sd_ms>: replays other hardware")
    exp.add_argument("--specs", choices=["pipeline", "oracle"], default="pipeline",
                     help="semantic methods: real perception (default) or specs given from ground truth")
    exp.add_argument("--gguf", type=gguf_file, action="append", default=[],
                     help="exp3: another GGUF model to compare (repeat)")
    exp.add_argument("--jobs", type=job_count, default=1,
                     help="episodes in parallel, each its own stack and bus port (default 1; a lockstep "
                          "episode keeps about one core busy: more jobs than cores only share them)")
    exp.add_argument("--timeout", type=episode_seconds, default=90.0,
                     help="episode time limit (sim seconds; default 90, the paper's; a landing takes 20-60 s)")
    exp.add_argument("--rrd", action="store_true", help="a Rerun recording per trial in OUT/rrd/")
    again = exp.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true", help="skip the trials already in OUT/trials.csv")
    again.add_argument("--overwrite", action="store_true",
                       help="an OUT that holds an earlier run: remove its results, plots, traces and logs first")
    exp.add_argument("--out", type=writable_dir, required=True, help="results folder")
    exp.set_defaults(func=cmd_experiment)


def _add_up_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    up = sub.add_parser("up", help="start the services locally, one process each; Ctrl-C stops all")
    up.add_argument("--services", nargs="+", default=["sim", "planner", "vle", "reasoner"],
                    choices=sorted(SERVICE_MODULES), help="which to start (default: sim planner vle reasoner)")
    one_or_many = up.add_mutually_exclusive_group()
    one_or_many.add_argument("--drone-id", type=drone_id, default="d0", help="the drone's id (one drone)")
    one_or_many.add_argument("--drones", type=drone_count, default=None, metavar="N",
                    help="N drones d0…d{N-1}, each its own sim, planner and VLE, on one reasoner")
    up.add_argument("--port", type=port, default=7447,
                    help="hub port on 127.0.0.1 (default 7447; `llmland mission --connect tcp/127.0.0.1:PORT`)")
    up.add_argument("--log-dir", type=writable_dir,
                    help="service logs: DIR/<service>.log (shared), DIR/<drone>/<service>.log")
    up.add_argument("--start-timeout", type=positive_seconds, default=180.0, help="seconds to wait for every service")
    up.set_defaults(func=cmd_up)


def _add_mission_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    mission = sub.add_parser("mission", help="send a mission to a running stack (`llmland up`); print its result")
    mission.add_argument("--world", choices=WORLDS, required=True)
    mission.add_argument("--seed", type=non_negative_int, required=True)
    mission.add_argument("--method", choices=METHODS, default="llm-land",
                         help="must match the running services (llm/llm-land need the VLE and the reasoner)")
    mission.add_argument("--drone-id", type=drone_id, default="d0")
    mission.add_argument("--connect", default=None,
                         help=f"comma-separated endpoints of the running stack or a router (client mode; default "
                              f"ZENOH_CONNECT or {DEFAULT_ENDPOINT}; a tls/ endpoint reads ZENOH_TLS_ROOT_CA, "
                              "ZENOH_TLS_CERTIFICATE, ZENOH_TLS_PRIVATE_KEY)")
    mission.add_argument("--timeout", type=episode_seconds, default=90.0, help="episode time limit (sim seconds)")
    mission.add_argument("--clock", choices=["lockstep", "realtime"], default="lockstep")
    mission.add_argument("--pedestrians", type=pedestrian_count, default=None)
    mission.add_argument("--wall-timeout", type=positive_seconds, default=None,
                         help="give up after this many wall seconds (the episode is then stopped)")
    mission.add_argument("--strict", action="store_true", help="exit 1 unless the landing succeeded")
    mission.set_defaults(func=cmd_mission)


def _add_bench_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    from .bench import BENCHMARKS

    bench = sub.add_parser("bench", help="print benchmark figures (median, p95)",
                           formatter_class=argparse.RawDescriptionHelpFormatter,
                           epilog="benchmarks:\n" + "\n".join(f"  {k:9s} {v}" for k, v in BENCHMARKS.items()))
    bench.add_argument("what", choices=list(BENCHMARKS), help="which benchmark (listed below)")
    bench.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    bench.add_argument("--quick", action="store_true",
                       help="fewer samples, and for `reasoner` only the rag mode and shorter fleet runs (for tests)")
    bench.set_defaults(func=cmd_bench)


def _add_ceiling_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    ceiling = sub.add_parser("ceiling", help="per seed, when the hard-limit gate would open with perfect perception "
                                             "(no method that keeps the limit can land where it never does)")
    ceiling.add_argument("--worlds", type=names_from(WORLDS), default=",".join(WORLDS), help="comma-separated")
    ceiling.add_argument("--seeds", type=seed_list, default="1-50", help="e.g. 1-50 or 1,4,7-9")
    ceiling.add_argument("--timeout", type=episode_seconds, default=90.0, help="episode time limit (sim seconds)")
    ceiling.add_argument("--pedestrians", type=pedestrian_count, default=None,
                         help="number of pedestrians (default: the "
                                                                         "world's; exp 1 flies 1)")
    ceiling.add_argument("--json", action="store_true", help="print the summary as JSON")
    ceiling.set_defaults(func=cmd_ceiling)


def cmd_ceiling(args: argparse.Namespace) -> int:
    from llmland_planner.settings import PlannerSettings

    from .ceiling import seed_ceiling, summary

    settings = PlannerSettings()
    rows = []
    with _stdout_to_stderr():  # pybullet prints to fd 1
        for world in args.worlds.split(","):
            for seed in args.seeds:
                row = seed_ceiling(world, seed, args.timeout, settings, args.pedestrians)
                rows.append(row)
                opens = "never opens" if row.first_open_s is None else f"first opens at {row.first_open_s:.1f} s"
                log.info("%s seed %d: the gate %s (open %.0f %% of the time; closest any person came to the "
                         "landing target: %.1f m, horizontally)",
                         world, seed, opens, 100 * row.open_fraction, row.closest_person_m)
    _print_figures(summary(rows, args.timeout, settings), as_json=args.json)
    return 0


def main(argv: list[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    configure_logging(args.log_level)
    # `kill -USR1 <pid>` prints every thread's stack to stderr: what a run that hangs waits on
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    # SIGTERM unwinds like Ctrl-C, so every context manager stops the services it started
    signal.signal(signal.SIGTERM, raise_keyboard_interrupt)
    try:
        sys.exit(args.func(args))
    except KeyboardInterrupt:
        sys.exit(130)
    except StartupError as exc:  # a service's own log says why; no traceback of the CLI's on top
        log.error("%s", exc)
        sys.exit(1)


if __name__ == "__main__":
    main()
