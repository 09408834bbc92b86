"""``llmland``: launch the services, fly episodes, run benchmarks (DESIGN §13)."""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from llmland_schemas import MissionGoal
from llmland_schemas.service import configure_logging, shutdown_event

from .episodes import PILOT_FOR_METHOD, EpisodeRunner, new_episode_id
from .launch import SERVICE_MODULES, Stack, free_port, hub_bus
from .oracle_specs import OracleSpecPublisher
from .results import summarize, write_results_csv

log = logging.getLogger("llmland")

WORLDS = ["open_field", "urban", "forest_edge"]
METHODS = list(PILOT_FOR_METHOD)


def _services_for(args: argparse.Namespace) -> list[str]:
    names = ["sim", PILOT_FOR_METHOD[args.method]]
    if _pipeline(args):
        names += ["vle", "reasoner"]
    return names


def _pipeline(args: argparse.Namespace) -> bool:
    """Semantic methods with real perception: VLE captions → reasoner specs."""
    return args.method in ("llm", "llm-land") and args.specs == "pipeline"


def _mission(args: argparse.Namespace, seed: int, rrd: str | None = None) -> MissionGoal:
    return MissionGoal(
        drone_id=args.drone_id,
        episode_id=new_episode_id(args.world, seed, args.method),
        world=args.world,
        seed=seed,
        method=args.method,
        clock=args.clock,
        timeout_s=args.timeout,
        n_pedestrians=args.pedestrians,
        rrd_path=rrd,
        max_rtf=1.0 if _pipeline(args) else None,
    )


@contextmanager
def _stack(args: argparse.Namespace) -> Iterator[EpisodeRunner]:
    """Hub session + service processes for ``args.method``; yields an episode runner."""
    port = args.port or free_port()
    env = {"LLMLAND_REASONER_MODE": "rag" if args.method == "llm-land" else "llm",
           "LLMLAND_REASONER_HTTP_PORT": str(free_port())}
    with hub_bus(port) as bus, Stack(port, args.drone_id, env=env, log_level=args.service_log_level) as stack:
        stack.start(_services_for(args))
        if args.specs == "oracle" and args.method in ("llm", "llm-land"):
            OracleSpecPublisher(bus, args.drone_id)
        stack.wait_alive(bus)
        yield EpisodeRunner(bus, args.drone_id)


def cmd_land(args: argparse.Namespace) -> int:
    rrd = str(Path(args.rrd).resolve()) if args.rrd else None
    with _stack(args) as runner:
        result = runner.run(_mission(args, args.seed, rrd))
    sys.stdout.write(result.model_dump_json(indent=2) + "\n")
    return 0 if result.success or not args.strict else 1


def _parse_seeds(text: str) -> list[int]:
    seeds: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        seeds += list(range(int(lo), int(hi or lo) + 1))
    return seeds


def cmd_trials(args: argparse.Namespace) -> int:
    """Many seeds on one running stack; a CSV row per episode and a summary line."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with _stack(args) as runner:
        for seed in _parse_seeds(args.seeds):
            r = runner.run(_mission(args, seed))
            rows.append(r)
            log.info("seed %d: %s (touchdown error %s m)", seed, r.outcome, r.touchdown_error_m)
    write_results_csv(out / "trials.csv", rows)
    summary = summarize(rows)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    sys.stdout.write(json.dumps(summary, indent=2) + "\n")
    return 0


def cmd_up(args: argparse.Namespace) -> int:
    stop = shutdown_event()
    port = args.port
    with hub_bus(port) as bus, Stack(port, args.drone_id, log_level=args.service_log_level) as stack:
        stack.start(args.services)
        stack.wait_alive(bus)
        log.info("services up on tcp/127.0.0.1:%d: %s — Ctrl-C stops all", port, ", ".join(args.services))
        while not stop.wait(0.5):
            for name, proc in stack.procs.items():
                if proc.poll() is not None:
                    log.error("%s exited with code %s", name, proc.returncode)
                    return 1
    return 0


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
    if args.json:
        sys.stdout.write(json.dumps(figures, indent=2) + "\n")
    else:
        for k, v in figures.items():
            sys.stdout.write(f"{k:40s} {v}\n")
    return 0


def _episode_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--world", choices=WORLDS, default="open_field")
    p.add_argument("--method", choices=METHODS, default="baseline")
    p.add_argument("--clock", choices=["lockstep", "realtime"], default="lockstep")
    p.add_argument("--timeout", type=float, default=90.0, help="episode time limit (sim seconds)")
    p.add_argument("--pedestrians", type=int, default=None, help="number of pedestrians (default: the world's)")
    p.add_argument("--specs", choices=["pipeline", "oracle", "none"], default="pipeline",
                   help="semantic methods: where specs come from — pipeline (VLE captions → reasoner), "
                        "oracle (given from ground truth), none")
    p.add_argument("--drone-id", default="d0")
    p.add_argument("--port", type=int, default=0, help="bus port (default: a free one)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="llmland", description=__doc__)
    parser.add_argument("--log-level", default="INFO")
    parser.add_argument("--service-log-level", default="WARNING", help="log level of the child services")
    sub = parser.add_subparsers(dest="command", required=True)

    land = sub.add_parser("land", help="fly one episode and print its EpisodeResult JSON")
    _episode_args(land)
    land.add_argument("--seed", type=int, default=1)
    land.add_argument("--rrd", help="write a Rerun recording of the episode to this file")
    land.add_argument("--strict", action="store_true", help="exit 1 unless the landing succeeded")
    land.set_defaults(func=cmd_land)

    trials = sub.add_parser("trials", help="fly many seeds on one stack; CSV + summary")
    _episode_args(trials)
    trials.add_argument("--seeds", default="1-20", help="e.g. 1-20 or 1,4,7-9")
    trials.add_argument("--out", default="runs/trials")
    trials.set_defaults(func=cmd_trials)

    up = sub.add_parser("up", help="start the services locally, one process each; Ctrl-C stops all")
    up.add_argument("--services", nargs="+", default=["sim", "planner", "vle", "reasoner"],
                    choices=sorted(SERVICE_MODULES))
    up.add_argument("--drone-id", default="d0")
    up.add_argument("--port", type=int, default=7447)
    up.set_defaults(func=cmd_up)

    bench = sub.add_parser("bench", help="print benchmark figures (median, p95)")
    bench.add_argument("what", choices=["bus", "sim", "mpc", "vle", "reasoner"])
    bench.add_argument("--json", action="store_true")
    bench.add_argument("--quick", action="store_true", help="fewer samples (for tests)")
    bench.set_defaults(func=cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    configure_logging(args.log_level)
    sys.exit(args.func(args))


if __name__ == "__main__":
    main()
