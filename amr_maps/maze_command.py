"""amr-maze: random maze worlds written as world files, for an instructor's exercises or a test bench.

    amr-maze perfect --count 5 --out mazes/             # mazes/perfect_0.yaml .. perfect_4.yaml
    amr-maze loops --seed 7 --size 4 --width 0.5 --set loop_fraction=0.3
    amr-maze all --out mazes/                           # one of each family
    amr-maze --list                                     # the families and their options
    ros2 run amr_maps maze bends --seed 3 --set bend_deg=120

Each file is a world (amr_maps.world) with walls, a start and a goal that a wall follower keeping the
--hand side reaches within the budget (amr_maps.maze_families); the same family, seed and options
always write the same file. Run one with `amr-bringup maze_sim world:=mazes/perfect_0.yaml`.
Exit status 2 with a message naming the bad family, option or value.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import yaml

from amr_maps.maze_families import FAMILIES, HANDS, MazeError, family_options, generate
from amr_maps.world import WorldError, world_from_dict

PROG = "amr-maze"


def maze_file(family: str, seed: int, out: Path, options: dict) -> Path:
    """Generate one maze, check it loads as a world, write it to out/<family>_<seed>.yaml; returns the path."""
    world = generate(family, seed, **options)
    world_from_dict(world, source=f"{family}_{seed}")  # the file written is a world the suite loads
    path = out / f"{world['name']}.yaml"
    given = " ".join(f"{key}={value}" for key, value in sorted(options.items()))
    header = (
        f"# {family} maze, seed {seed}{', ' + given if given else ''}: written by `{PROG}` (amr_maps.maze_families)\n"
    )
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(
        header + yaml.safe_dump(world, sort_keys=False, default_flow_style=None, width=120), encoding="utf-8"
    )
    return path


def _parse_set(items: Sequence[str]) -> dict[str, float]:
    values: dict[str, float] = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise MazeError(f"--set {item!r}: expected NAME=VALUE")
        try:
            values[name] = float(text) if any(c in text for c in ".eE") else int(text)
        except ValueError:
            raise MazeError(f"--set {item!r}: {text!r} is not a number") from None
    return values


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="families: " + ", ".join(FAMILIES),
    )
    parser.add_argument("family", nargs="?", help="a maze family, or 'all' for one of each")
    parser.add_argument("--seed", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("--count", type=int, default=1, help="mazes per family, seeds seed .. seed + count - 1")
    parser.add_argument("--out", default=".", help="directory to write <family>_<seed>.yaml into (default .)")
    parser.add_argument("--size", type=float, help="m, side of the maze or room (3-8; default: drawn)")
    parser.add_argument("--width", type=float, help="m, corridor width (0.35-0.6; default: drawn)")
    parser.add_argument("--thickness", type=float, help="m, wall thickness (default: drawn)")
    parser.add_argument("--hand", choices=HANDS, help="the wall follower's side the goal is placed for (default right)")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a family option, e.g. loop_fraction=0.3, bend_deg=120, bends=4 (see --list)",
    )
    parser.add_argument("--list", action="store_true", help="print the families and their options, then exit")
    args = parser.parse_args(argv)
    if args.list:
        for family in FAMILIES:
            print(f"{family}: {', '.join(family_options(family))}")
        return 0
    if args.family is None:
        parser.print_usage(sys.stderr)
        print(f"{PROG}: a family is required (one of {', '.join(FAMILIES)}, or all)", file=sys.stderr)
        return 2
    families = FAMILIES if args.family == "all" else (args.family,)
    try:
        if args.count < 1:
            raise MazeError(f"--count must be at least 1, got {args.count}")
        options = {
            name: getattr(args, name)
            for name in ("size", "width", "thickness", "hand")
            if getattr(args, name) is not None
        }
        options.update(_parse_set(args.set))
        for family in families:
            for seed in range(args.seed, args.seed + args.count):
                print(f"{PROG}: wrote {maze_file(family, seed, Path(args.out), dict(options))}")
    except (MazeError, WorldError, OSError) as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
