"""amr-evaluate: sweep controllers and configurations over worlds, maze families, seeds and noise levels.

    amr-evaluate --run wall_follower=sim --run wall_follower=real --families all --seeds 5 \\
        --lidar-noise 0.01 0.03 --encoder-noise 0.02 --slip 0.05 --out results/wf.jsonl
    amr-evaluate --run navigation --worlds hard_maze pillar_goal --seeds 3 --workers 2
    amr-evaluate --run wall_follower=my_follower.yaml --families perfect bends --seeds 20 \\
        --scheduler tcp://10.0.0.5:8786
    amr-evaluate --run 'command=python3 student.py' --mode ros --families perfect --seeds 100

Every episode (controller x configuration x world x seed x noise) is keyed by a hash of its whole spec;
its record is appended to the results file (JSON lines) when it finishes, and a sweep started again with
the same file skips every finished episode (it says how many). At the end: a summary table (also
<stem>.summary.txt) and plots beside the results (<stem>.success.png, <stem>.time_to_goal.png,
<stem>.localization.png). A parameter file is checked against the nodes' own parameter statements before
anything runs. Ctrl-C stops the sweep with one line (what finished is kept: run the same command to resume).
Exit status: 0 done, 1 an episode raised, 2 bad input or no scheduler, 130 interrupted.
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from amr_evaluation import configs
from amr_evaluation.episode import MODES, EpisodeSpec
from amr_evaluation.interrupt import Interrupt
from amr_evaluation.worlds import WorldSpecError, world_spec_of_file

DEFAULT_OUT = "out/evaluation/results.jsonl"


def parse_arguments(argv: Sequence[str] | None) -> argparse.Namespace:
    from amr_maps.maze_families import FAMILIES

    parser = argparse.ArgumentParser(
        prog="amr-evaluate",
        description=__doc__.split("\n\n")[0],
        epilog=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    what = parser.add_argument_group("what to run")
    what.add_argument(
        "--run",
        action="append",
        metavar="CONTROLLER[=CONFIG]",
        help="a controller and its configuration, repeatable: wall_follower=sim (default), "
        "wall_follower=real, wall_follower=my.yaml (laid over sim; real:my.yaml over real), "
        "navigation (=default or a file), localization, plan_follow, "
        "'command=python3 student.py' (your own node, --mode ros)",
    )
    what.add_argument(
        "--worlds",
        nargs="+",
        default=[],
        metavar="WORLD",
        help="world files: shipped names (hard_maze, pillar_goal.yaml) or paths",
    )
    what.add_argument(
        "--families",
        nargs="+",
        default=[],
        metavar="FAMILY",
        help=f"generated maze families, or 'all' ({', '.join(FAMILIES)})",
    )
    what.add_argument("--seeds", type=int, default=1, help="seeds 0..N-1 (mazes per family; runs per world file)")
    what.add_argument("--first-seed", type=int, default=0)
    what.add_argument("--width", type=float, help="corridor width of the generated mazes (m; default: drawn)")
    what.add_argument("--size", type=float, help="side of the generated mazes (m; default: drawn)")
    what.add_argument("--goal", default="world", help="world (the world's own), far, random or x,y,radius")
    what.add_argument("--lidar-noise", type=float, nargs="+", default=[0.01], metavar="M")
    what.add_argument("--encoder-noise", type=float, nargs="+", default=[0.0])
    what.add_argument("--slip", type=float, nargs="+", default=[0.0])
    what.add_argument("--duration", type=float, default=600.0, help="s simulated at most (default 600)")
    what.add_argument(
        "--beams",
        type=int,
        help="wall_follower: LiDAR beams (default 240, or 360 as the LDS-01 has for "
        "a configuration with simulation: false, e.g. real)",
    )
    what.add_argument("--scan-period", type=float, help="wall_follower: s between scans, the command held between")
    what.add_argument("--outliers", type=float, default=0.0, help="wall_follower: per-beam spurious return rate")
    what.add_argument(
        "--mode",
        choices=MODES,
        default="library",
        help="library (no DDS, default) or ros (the amr-bringup stack per episode)",
    )
    what.add_argument(
        "--clock",
        choices=("lockstep", "realtime"),
        default="lockstep",
        help="command: the simulator steps once per /cmd_vel (lockstep, default) or on its timer",
    )
    what.add_argument("--pace", type=float, default=1.0, help="command, --clock realtime: x real time (default 1)")
    what.add_argument(
        "--answer-timeout",
        type=float,
        default=10.0,
        metavar="S",
        help="command: wall-clock s without a /cmd_vel before the node is given up (default 10)",
    )
    what.add_argument(
        "--cmd-vel-stamped",
        action="store_true",
        help="command: the node publishes TwistStamped on /cmd_vel (default: plain Twist)",
    )
    what.add_argument(
        "--ros-domains",
        metavar="FIRST-LAST",
        help="--mode ros: the ROS domains episodes take one each of (default: $AMR_EVALUATE_ROS_DOMAINS "
        "or 120-199; Dask workers read their own environment)",
    )
    where = parser.add_argument_group("where")
    where.add_argument("--workers", type=int, default=None, help="local processes (default 2, or the cores if fewer)")
    where.add_argument("--scheduler", metavar="tcp://HOST:8786", help="run on this Dask cluster instead")
    where.add_argument(
        "--scheduler-timeout",
        type=float,
        default=10.0,
        metavar="S",
        help="s to wait for the scheduler to answer (default 10): then an error, nothing written",
    )
    where.add_argument("--out", default=DEFAULT_OUT, help=f"results file, JSON lines (default {DEFAULT_OUT})")
    where.add_argument("--no-plots", action="store_true")
    where.add_argument("--no-progress", action="store_true")
    where.add_argument("--list", action="store_true", help="print the episodes and exit")
    options = parser.parse_args(argv)
    if options.workers is not None and options.scheduler:
        parser.error("--workers and --scheduler exclude each other (the cluster has its own workers)")
    if options.workers is not None and options.workers < 1:
        parser.error("--workers must be at least 1")
    if options.seeds < 1 or options.first_seed < 0:
        parser.error("--seeds must be at least 1 and --first-seed at least 0")
    if options.duration <= 0:
        parser.error("--duration must be positive")
    if not options.scheduler_timeout > 0:
        parser.error("--scheduler-timeout must be positive")
    if "all" in options.families:
        options.families = list(FAMILIES)
    unknown = [f for f in options.families if f not in FAMILIES]
    if unknown:
        parser.error(f"--families: unknown {unknown[0]!r} (known: {', '.join(FAMILIES)}, all)")
    if not options.worlds and not options.families:
        parser.error("give --worlds, --families, or both")
    options.goal = _goal(parser, options.goal)
    if options.ros_domains is not None:
        first, _, last = options.ros_domains.partition("-")
        if not (first.isdigit() and last.isdigit() and int(first) <= int(last) <= 232):
            parser.error(f"--ros-domains {options.ros_domains!r}: expected FIRST-LAST within 0-232, e.g. 48-55")
    return options


def _goal(parser: argparse.ArgumentParser, text: str):
    if text in ("world", "far", "random"):
        return None if text == "world" else text
    try:
        x, y, radius = (float(v) for v in text.split(","))
    except ValueError:
        parser.error(f"--goal {text!r}: expected world, far, random or x,y,radius")
    return [x, y, radius]


def runs_of(options: argparse.Namespace) -> list[tuple[str, str, dict]]:
    """(controller, label, parameters) of every --run."""
    runs = []
    for text in options.run or ["wall_follower=sim"]:
        controller, _, config = text.partition("=")
        config = config or ("sim" if controller == "wall_follower" else "default")
        label, parameters = configs.resolve(controller, config)
        runs.append((controller, label, parameters))
    return runs


def build_specs(options: argparse.Namespace) -> list[EpisodeSpec]:
    """The sweep's episodes: every run x world x seed x noise level, in that order."""
    seeds = range(options.first_seed, options.first_seed + options.seeds)
    specs = []
    wall_options = {
        k: v
        for k, v in (
            ("beams", options.beams),
            ("scan_period", options.scan_period),
            ("outlier_rate", options.outliers or None),
        )
        if v is not None
    }
    for controller, label, parameters in runs_of(options):
        hand = parameters.get("wall_follower", {}).get("preferred_wall", "right")
        hand = hand if hand in ("right", "left") else "right"
        worlds = []
        for name in options.worlds:
            worlds += [(world_spec_of_file(name), seed) for seed in seeds]
        for family in options.families:
            maze_options = {"hand": hand}
            if options.width is not None and family not in ("pillars", "open_room"):
                maze_options["width"] = options.width
            if options.size is not None:
                maze_options["size"] = options.size
            worlds += [({"family": family, "seed": seed, "options": maze_options}, seed) for seed in seeds]
        extra = dict(wall_options) if controller == "wall_follower" else {}
        if controller == "command":
            if options.mode != "ros":
                raise ValueError("--run command=...: a node of your own runs through ROS only: add --mode ros")
            extra = {
                "clock": options.clock,
                "answer_timeout": options.answer_timeout,
                "cmd_vel_stamped": options.cmd_vel_stamped,
                **({"beams": options.beams} if options.beams else {}),
            }
            if options.clock == "realtime":
                extra["pace"] = options.pace
        if (
            controller == "wall_follower"
            and options.beams is None
            and parameters["wall_follower"].get("simulation") is False
        ):
            extra["beams"] = 360  # the real robot's LDS-01
        for (world, seed), lidar, encoder, slip in itertools.product(
            worlds, options.lidar_noise, options.encoder_noise, options.slip
        ):
            specs.append(
                EpisodeSpec(
                    controller,
                    label,
                    parameters,
                    world,
                    options.goal,
                    seed,
                    lidar,
                    encoder,
                    slip,
                    options.duration,
                    dict(extra),
                    options.mode,
                )
            )
    return specs


def main(argv: Sequence[str] | None = None) -> int:
    """The command; Ctrl-C at any moment after the arguments are read ends it with one line and INTERRUPTED (130):
    amr_evaluation.interrupt says how, whatever the interrupt lands in (a pool starting, a __del__, ...)."""
    options = parse_arguments(argv)
    with Interrupt(
        f"amr-evaluate: interrupted; the finished episodes are in {options.out} (the same command resumes)"
    ) as interrupt:
        try:
            code = _main(options, interrupt.is_set)
        except KeyboardInterrupt:
            return interrupt.report()
        except Exception:
            if interrupt.is_set():  # what the interrupt broke (a pool whose workers it ended) is the interrupt
                return interrupt.report()
            raise
        return interrupt.report() if interrupt.is_set() else code  # it landed where it was swallowed


def _main(options: argparse.Namespace, stop: Callable[[], bool] | None = None) -> int:
    try:
        specs = build_specs(options)
    except (configs.ConfigurationError, WorldSpecError, ValueError) as error:
        print(f"amr-evaluate: {error}", file=sys.stderr)
        return 2
    if options.list:
        for spec in specs:
            print(
                spec.key,
                spec.controller,
                spec.config,
                spec.world.get("family") or spec.world.get("file") or spec.world.get("name"),
                f"seed {spec.seed}",
                f"lidar {spec.lidar_noise}",
                f"encoders {spec.encoder_noise}",
                f"slip {spec.slip}",
            )
        return 0
    from amr_evaluation.plots import write_plots
    from amr_evaluation.records import format_summary, summarize
    from amr_evaluation.runner import SweepError, default_workers, run_sweep

    if options.ros_domains is not None:
        from amr_evaluation.ros_episode import DOMAINS_VARIABLE

        os.environ[DOMAINS_VARIABLE] = options.ros_domains  # local workers inherit it
    out = Path(options.out)
    workers = options.workers or default_workers()
    where = f"Dask scheduler {options.scheduler}" if options.scheduler else f"{workers} local worker(s)"
    print(f"amr-evaluate: {len(specs)} episodes on {where}; results in {out}", flush=True)

    def started(skipped: int, to_run: int) -> None:
        if skipped:
            print(f"amr-evaluate: resuming {out}: {skipped} finished episode(s) skipped, {to_run} to run", flush=True)

    try:
        records = run_sweep(
            specs,
            out,
            workers=workers,
            scheduler=options.scheduler,
            progress=not options.no_progress,
            on_start=started,
            connect_timeout=options.scheduler_timeout,
            stop=stop,
        )
    except SweepError as error:
        print(f"amr-evaluate: {error}", file=sys.stderr)
        return 2
    table = format_summary(summarize(records))
    print(table)
    summary_path = out.with_name(f"{out.stem}.summary.txt")
    summary_path.write_text(table + "\n", encoding="utf-8")
    written = [] if options.no_plots else write_plots(records, out)
    print(f"summary: {summary_path}" + (f"; plots: {', '.join(str(p) for p in written)}" if written else ""))
    failed = [r for r in records if r.get("error")]
    for record in failed[:5]:
        print(
            f"episode {record['key']} ({record['controller']} {record['world']} seed {record['seed']}) failed: "
            f"{record['error']}",
            file=sys.stderr,
        )
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
