"""Localization figures: update cost, global localization while wall following, kidnapping,
symmetric worlds, the beacon localizer's pyramidal search against the exhaustive grid, and, on the beacon
world (open_room), the beacon localizer against the particle filter with beacons, scan + beacons and scan.
--symmetry: generated square rooms whose four-fold symmetry one feature breaks (a doorway, a
notch, a missing or an extra pillar; amr_maps.symmetry_families) and truly symmetric controls
(docs/decisions/2026-11-27-symmetry-evidence-ledger.md).
--crowded: a robot localizing while 1-5 other robots, not on the map, stand or drive near it and fill
part of its scan (amr_evaluation.crowded_localization; docs/fleet.md).

The sweeps (global localization, symmetric worlds, kidnapping) are amr_evaluation episodes (controller
`localization`: config/wall_follower_sim.yaml and config/particle_filter.yaml) run by its runner: --jobs N local
processes, --scheduler tcp://host:8786 a Dask cluster, --results FILE keeps the records and resumes from them.

Prints; asserts nothing.
Usage: .venv/bin/python bench/bench_localization.py [--quick] [--jobs 2] [--beacon-comparison | --symmetry (that alone)]
       [--seeds N (--symmetry: seeds per family)]
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from amr_control.wall_follower import WallFollower
from amr_control.wall_follower_config import read_parameter_file
from amr_evaluation import configs
from amr_evaluation.episode import EpisodeSpec
from amr_evaluation.runner import run_sweep
from amr_localization.beacon_localizer import BeaconLocalizer, BeaconLocalizerConfig
from amr_localization.beacons import BeaconReading, expected_ranges
from amr_localization.distance_field import DistanceField
from amr_localization.likelihood_field import LikelihoodField, LikelihoodFieldParams
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_config import ParticleFilterConfig
from amr_localization.scan_beams import select_beams
from amr_localization.sensor_mount import SensorMount
from amr_maps.rasterize import rasterize_world
from amr_maps.symmetry_families import BROKEN, SYMMETRIC, symmetry_case
from amr_maps.world import World, load_world
from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.geometry import wrap_angle
from amr_util.scan import scan_of

ROOT = Path(__file__).resolve().parents[1]

WORLDS = ROOT / "config" / "worlds"
FOLLOWER = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
RESOLUTION = 0.02


def random_maze(seed: int) -> dict:
    """A perfect maze (depth-first carving) of random size 3-8 m and corridor 0.35-0.6 m, plus a few loops."""
    rng = np.random.default_rng(seed)
    corridor = float(rng.uniform(0.35, 0.6))
    side = float(rng.uniform(3.0, 8.0))
    cols = max(3, int(side / corridor))
    rows = max(3, int(float(rng.uniform(3.0, 8.0)) / corridor))
    open_walls = set()
    visited = {(0, 0)}
    stack = [(0, 0)]
    while stack:
        r, c = stack[-1]
        options = [
            (r + dr, c + dc)
            for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1))
            if 0 <= r + dr < rows and 0 <= c + dc < cols and (r + dr, c + dc) not in visited
        ]
        if not options:
            stack.pop()
            continue
        nxt = options[rng.integers(len(options))]
        open_walls.add(frozenset([(r, c), nxt]))
        visited.add(nxt)
        stack.append(nxt)
    for _ in range(rows * cols // 10):  # loops, so a wall follower sees more than one wall
        r, c = int(rng.integers(rows - 1)), int(rng.integers(cols - 1))
        open_walls.add(frozenset([(r, c), (r + 1, c) if rng.random() < 0.5 else (r, c + 1)]))
    walls = [
        [0, 0, cols * corridor, 0],
        [0, rows * corridor, cols * corridor, rows * corridor],
        [0, 0, 0, rows * corridor],
        [cols * corridor, 0, cols * corridor, rows * corridor],
    ]
    for r in range(rows):
        for c in range(cols):
            if c + 1 < cols and frozenset([(r, c), (r, c + 1)]) not in open_walls:
                walls.append([(c + 1) * corridor, r * corridor, (c + 1) * corridor, (r + 1) * corridor])
            if r + 1 < rows and frozenset([(r, c), (r + 1, c)]) not in open_walls:
                walls.append([c * corridor, (r + 1) * corridor, (c + 1) * corridor, (r + 1) * corridor])
    start_r, start_c = int(rng.integers(rows)), int(rng.integers(cols))
    start = [(start_c + 0.5) * corridor, (start_r + 0.5) * corridor, float(rng.uniform(-math.pi, math.pi))]
    data = {
        "name": f"maze{seed}_{cols}x{rows}_{corridor:.2f}",
        "wall_thickness": 0.02,
        "walls": [[float(v) for v in w] for w in walls],
        "start": start,
    }
    return data


def bench_update_cost(repeats: int) -> None:
    print("== likelihood-field measurement update (ms, median), inner_maze at 2 cm, one core")
    world = load_world(WORLDS / "inner_maze.yaml")
    sim = Simulator(world, SimulationConfig())
    field = DistanceField(rasterize_world(world, RESOLUTION))
    model = LikelihoodField(field, LikelihoodFieldParams(), SensorMount(x=sim.lidar.x), sim.lidar.range_max)
    scan = scan_of(sim)
    beam_counts = (30, 60, 120)
    print(f"{'particles':>10}" + "".join(f"{b:>10} beams" for b in beam_counts))
    rng = np.random.default_rng(0)
    for count in (500, 1000, 2000, 5000):
        particles = np.column_stack(
            [rng.uniform(-1.1, 1.1, count), rng.uniform(-1.1, 1.1, count), rng.uniform(-math.pi, math.pi, count)]
        )
        cells = []
        for beams in beam_counts:
            selected = select_beams(scan, beams)
            times = []
            for _ in range(repeats):
                started = time.perf_counter()
                model.log_likelihood(particles, selected)
                times.append(time.perf_counter() - started)
            cells.append(f"{1e3 * np.median(times):16.2f}")
        print(f"{count:>10}" + "".join(cells))
    print(
        "== whole filter update (motion + likelihood field + resampling + place hypotheses + place search), "
        "5000 particles, 60 beams"
    )
    pf = ParticleFilter(
        rasterize_world(world, RESOLUTION), ParticleFilterConfig(min_particles=5000, max_particles=5000)
    )
    times = []
    for step in range(repeats):
        started = time.perf_counter()
        pf.update((0.03 * step, 0.0, 0.0), scan)  # moves update_min_d every call: every call is a full update
        times.append(time.perf_counter() - started)
    print(f"median {1e3 * np.median(times):.2f} ms, p90 {1e3 * np.percentile(times, 90):.2f} ms")


LABEL, PARAMETERS = configs.resolve("localization", "default")


def localization_spec(
    world: dict, seed: int, lidar_noise: float, encoder_noise: float, slip: float, seconds: float, kidnap=None
) -> EpisodeSpec:
    return EpisodeSpec(
        "localization",
        LABEL,
        PARAMETERS,
        world,
        None,
        seed,
        lidar_noise,
        encoder_noise,
        slip,
        seconds,
        {"kidnap": [kidnap[0], *kidnap[1]]} if kidnap else {},
    )


class Sweep:
    """Where the localization episodes run, and the records file they resume from."""

    def __init__(self, jobs: int, scheduler: str | None, results: str | None) -> None:
        self.jobs, self.scheduler = jobs, scheduler
        if results is None:
            out = ROOT / "out" / "bench"
            out.mkdir(parents=True, exist_ok=True)
            results = Path(tempfile.mkdtemp(prefix="localization_", dir=out)) / "records.jsonl"
        self.results = results

    def run(self, specs: list[EpisodeSpec]) -> list[dict]:
        return run_sweep(specs, self.results, workers=self.jobs, scheduler=self.scheduler, progress=False)


def summarize(name: str, record: dict) -> dict:
    first = record["time_to_localized"]
    result = {"name": name, "localized": first is not None and first <= 60.0, "wall": record["wall_time"]}
    if record["error"]:
        print(f"{name:28s} run failed: {record['error']}")
        result["localized"] = None
        return result
    if first is None:
        print(f"{name:28s} never localized ({record['time']:.0f} s)  wall {record['wall_time']:5.1f} s")
        return result
    extra = record["extra"]
    result.update(
        time=first,
        error=record["localization_error"],
        heading=extra["heading_error"],
        rms=record["localization_rms"],
        rms_heading=extra["heading_rms"],
        withdrawn=record["localization_losses"],
    )
    print(
        f"{name:28s} localized at {first:5.1f} s  error {100 * result['error']:5.1f} cm {result['heading']:4.1f} deg"
        f"  RMS after {100 * result['rms']:4.1f} cm {result['rms_heading']:4.2f} deg  withdrawals "
        f"{result['withdrawn']}  wall {record['wall_time']:5.1f} s"
    )
    return result


def bench_global(sweep: Sweep, seeds: int, mazes: int, seconds: float) -> None:
    print(
        f"== global localization while wall following ({seconds:.0f} s simulated; lidar noise 0.01-0.03 m, "
        "encoder noise 0-0.03, slip 0-0.05)"
    )
    rng = np.random.default_rng(12)
    cases = [({"file": path.name}, path.stem) for path in sorted(WORLDS.glob("*.yaml")) if path.stem != "twin_rooms"]
    runs = [(world, name, seed) for world, name in cases for seed in range(seeds)]
    for seed in range(100, 100 + mazes):
        data = random_maze(seed)
        runs.append(({"data": data, "name": data["name"]}, data["name"], seed))
    specs = []
    for world, _, seed in runs:
        noise = (float(rng.uniform(0.01, 0.03)), float(rng.uniform(0.0, 0.03)), float(rng.uniform(0.0, 0.05)))
        specs.append(localization_spec(world, seed, *noise, seconds))
    results = [
        summarize(f"{name} s{seed}", record) for (_, name, seed), record in zip(runs, sweep.run(specs), strict=True)
    ]
    results = [r for r in results if r["localized"] is not None]  # a run that failed is reported, not counted
    ok = [r for r in results if r["localized"]]
    print(f"localized within 60 s: {len(ok)}/{len(results)} ({100 * len(ok) / max(len(results), 1):.0f} %)")
    if ok:
        print(
            f"error at first declaration: max {100 * max(r['error'] for r in ok):.1f} cm, "
            f"max {max(r['heading'] for r in ok):.1f} deg; within 10 cm and 10 deg: "
            f"{sum(r['error'] <= 0.1 and r['heading'] <= 10 for r in ok)}/{len(ok)}"
        )
        print(
            f"RMS while localized: worst {100 * max(r['rms'] for r in ok):.1f} cm, "
            f"{max(r['rms_heading'] for r in ok):.2f} deg; median {100 * np.median([r['rms'] for r in ok]):.1f} cm, "
            f"{np.median([r['rms_heading'] for r in ok]):.2f} deg"
        )
        withdrawals = sum(r["withdrawn"] for r in ok)
        print(f"withdrawals while localized: {withdrawals} in {len(ok)} runs")


def bench_symmetric(sweep: Sweep, seeds: int, seconds: float) -> None:
    print(f"== twin_rooms (two identical rooms, symmetric under a half turn): {seconds:.0f} s each")
    specs = [localization_spec({"file": "twin_rooms.yaml"}, seed, 0.02, 0.02, 0.03, seconds) for seed in range(seeds)]
    false = 0
    for seed, record in enumerate(sweep.run(specs)):
        first = record["time_to_localized"]
        false += first is not None
        print(
            f"seed {seed}: {f'LOCALIZED at {first:.1f} s' if first is not None else 'never localized'}  "
            f"wall {record['wall_time']:.1f} s" + (f"  ERROR {record['error']}" if record["error"] else "")
        )
    print(f"false declarations: {false}/{seeds}")


def bench_kidnap(sweep: Sweep, seeds: int) -> None:
    print("== kidnapping (teleport at 30 s, the filter not told)")
    targets = {
        "inner_maze": [(-1.0, 1.0, 0.0), (1.0, 0.2, 3.0), (-0.2, -1.0, 1.5)],
        "hard_maze": [(-1.3, 1.25, 0.0), (1.3, -1.2, 1.6), (0.25, 0.35, -1.6)],
    }
    cases = [(name, seed, pose) for name, poses in targets.items() for seed, pose in enumerate(poses[:seeds])]
    specs = [
        localization_spec({"file": f"{name}.yaml"}, seed, 0.02, 0.02, 0.03, 100.0, kidnap=(30.0, pose))
        for name, seed, pose in cases
    ]
    for (name, seed, pose), record in zip(cases, sweep.run(specs), strict=True):
        if record["error"]:
            print(f"{name} -> {pose}: {record['error']}")
            continue
        extra = record["extra"]
        withdrawn = extra["withdrawn_after"] if extra["withdrawn_after"] is not None else math.inf
        regained = extra["regained_after"] if extra["regained_after"] is not None else math.inf
        error = (
            f"{100 * extra['regained_error']:.1f} cm {extra['regained_heading_error']:.1f} deg"
            if extra["regained_after"] is not None
            else "-"
        )
        print(
            f"{name} seed {seed}: localized before {extra['localized_before']}, withdrawn after {withdrawn:.2f} s, "
            f"regained after {regained:.1f} s (error {error})"
        )


def _noise(rng: np.random.Generator) -> tuple[float, float, float]:
    return float(rng.uniform(0.01, 0.03)), float(rng.uniform(0.005, 0.03)), float(rng.uniform(0.01, 0.05))


def bench_symmetry(sweep: Sweep, seeds: int, seconds: float, control_seeds: int, control_seconds: float) -> None:
    after = 15.0
    print(
        f"== symmetry broken by one feature: {len(BROKEN)} families x {seeds} seeds, "
        f"square rooms 3.5-6.5 m, features 0.2-0.6 m, LiDAR noise 0.01-0.03 m, encoder noise 0.005-0.03, "
        f"slip 0.01-0.05; until {after:.0f} s after the first declaration with the feature seen, "
        f"at most {seconds:.0f} s simulated. 'seen': 3 noise-free "
        "beams of the scan (240) see the feature (differ by > 5 cm from the symmetric room), 'glimpsed': one does; "
        "'apart': by then every quarter turn of the pose has been told apart by 3 beams at least once (the feature, "
        "or a wall where a turned copy would see it)"
    )
    rng = np.random.default_rng(20)
    cases, specs = [], []
    for kind in BROKEN:
        for seed in range(seeds):
            noise = _noise(rng)
            case = symmetry_case(kind, seed)
            cases.append((case, noise))
            specs.append(
                EpisodeSpec(
                    "localization",
                    LABEL,
                    PARAMETERS,
                    {"data": case.world, "name": case.world["name"]},
                    None,
                    seed,
                    *noise,
                    seconds,
                    {"symmetric": case.symmetric, "stop_after": after},
                )
            )
    rows = []
    for (case, noise), record in zip(cases, sweep.run(specs), strict=True):
        name = case.world["name"]
        if record["error"]:
            print(f"{name:18s} run failed: {record['error']}")
            continue
        extra = record["extra"]
        seen, glimpsed, apart = extra["feature_seen"], extra["feature_glimpsed"], extra["turns_apart"]
        first = record["time_to_localized"]
        row = {
            "kind": case.kind,
            "seen": seen,
            "apart": apart,
            "time": first,
            "error": record["localization_error"],
            "heading": extra.get("heading_error"),
            "withdrawn": record["localization_losses"] or 0,
        }
        right = first is not None and row["error"] <= 0.10 and row["heading"] <= 10.0
        row["ok"] = right and (seen is None or first <= seen + 60.0)
        row["ok_glimpsed"] = right and (glimpsed is None or first <= glimpsed + 60.0)
        row["counted"] = seen is not None or first is not None
        rows.append(row)
        if first is not None:
            when = (
                f"localized at {first:5.1f} s, error {100 * row['error']:4.1f} cm {row['heading']:4.1f} deg, "
                f"{row['withdrawn']} withdrawals in the {record['time'] - first:.0f} s after"
            )
        else:
            when = f"never localized in {record['time']:.0f} s"
        verdict = "ok" if row["ok"] else "MISSED" if row["counted"] else "(never seen nor localized: not counted)"
        nan = math.nan
        print(
            f"{name:18s} noise {noise[0]:.3f}/{noise[1]:.3f}/{noise[2]:.3f}  seen at "
            f"{seen if seen is not None else nan:5.1f} s "
            f"(glimpsed {glimpsed if glimpsed is not None else nan:5.1f} s), "
            f"apart at {apart if apart is not None else nan:5.1f} s, {when}  {verdict}  CPU per observation "
            f"{1e3 * (extra['update_time_mean'] or 0.0):.2f} ms mean  wall {record['wall_time']:5.1f} s",
            flush=True,
        )
    counted = [r for r in rows if r["counted"]]
    ok = [r for r in counted if r["ok"]]
    print(
        f"localized within 60 s of the feature first in view (or before it), error <= 10 cm and 10 deg: "
        f"{len(ok)}/{len(counted)} ({100 * len(ok) / max(len(counted), 1):.0f} %); counting from the first beam "
        f"that grazes it: {sum(r['ok_glimpsed'] for r in counted)}/{len(counted)}"
    )
    for kind in BROKEN:
        mine = [r for r in counted if r["kind"] == kind]
        delays = [r["time"] - r["seen"] for r in mine if r["time"] is not None and r["seen"] is not None]
        strict = [r["time"] - r["apart"] for r in mine if r["time"] is not None and r["apart"] is not None]
        print(
            f"  {kind:15s} {sum(r['ok'] for r in mine)}/{len(mine)}  after first seen: "
            + (f"median {np.median(delays):5.1f} s, max {max(delays):5.1f} s" if delays else "-")
            + "; after every turn told apart: "
            + (f"median {np.median(strict):5.1f} s, max {max(strict):5.1f} s" if strict else "-")
        )
    declared = [r for r in rows if r["time"] is not None]
    if declared:
        print(
            f"error at the first declaration: max {100 * max(r['error'] for r in declared):.1f} cm, "
            f"{max(r['heading'] for r in declared):.1f} deg; wrong (> 10 cm or 10 deg): "
            f"{sum(r['error'] > 0.10 or r['heading'] > 10.0 for r in declared)}/{len(declared)}; withdrawals after it: "
            f"{sum(r['withdrawn'] for r in declared)}"
        )
    print(
        f"== truly symmetric controls, {control_seconds:.0f} s each: twin_rooms, and {', '.join(SYMMETRIC)} with "
        "coordinates on the 2 cm lattice (the map exactly as symmetric as the world) and off it (the map not quite)"
    )
    controls = [({"file": "twin_rooms.yaml"}, f"twin_rooms s{seed}", seed) for seed in range(control_seeds)]
    for kind in SYMMETRIC:
        for seed in range(control_seeds):
            for lattice in (True, False):
                case = symmetry_case(kind, seed, lattice=lattice)
                name = f"{case.world['name']}{'' if lattice else '_off'}"
                controls.append(({"data": case.world, "name": name}, name, seed))
    noises = [_noise(rng) for _ in controls]
    specs = [
        EpisodeSpec("localization", LABEL, PARAMETERS, world, None, seed, *noise, control_seconds, {"stop_after": 0.0})
        for (world, _, seed), noise in zip(controls, noises, strict=True)
    ]
    false = 0
    for (_, name, _), noise, record in zip(controls, noises, sweep.run(specs), strict=True):
        first = record["time_to_localized"]
        false += first is not None
        print(
            f"{name:22s} noise {noise[0]:.3f}/{noise[1]:.3f}/{noise[2]:.3f}  "
            f"{f'LOCALIZED at {first:.1f} s' if first is not None else 'never localized'}  CPU per observation "
            f"{1e3 * (record['extra'].get('update_time_mean') or 0.0):.2f} ms mean  wall {record['wall_time']:5.1f} s"
            + (f"  ERROR {record['error']}" if record["error"] else ""),
            flush=True,
        )
    print(f"false declarations in truly symmetric worlds: {false}/{len(controls)}")


def bench_beacons(cases: int) -> None:
    print("== beacon localizer: pyramidal vs exhaustive grid at the same final resolution (5 mm), range noise 5 mm")
    beacons = np.array([[0.0, 0.0], [4.0, 0.5], [3.5, 4.0], [0.5, 3.5]])
    rng = np.random.default_rng(0)
    rows = []
    for _ in range(cases):
        truth = (rng.uniform(0.5, 3.5), rng.uniform(0.5, 3.5), rng.uniform(-math.pi, math.pi))
        guess = (truth[0] + rng.uniform(-1, 1), truth[1] + rng.uniform(-1, 1), 0.0)
        ranges = expected_ranges(np.array([truth[:2]]), beacons)[0] + rng.normal(0, 0.005, 4)
        reading = BeaconReading.checked(ranges, truth[2], 4)
        result = []
        for pyramidal in (True, False):
            localizer = BeaconLocalizer(beacons, BeaconLocalizerConfig(resolution=0.005), initial_pose=guess)
            started = time.perf_counter()
            found = localizer.relocalize(reading, pyramidal=pyramidal)
            result.append(
                (
                    math.hypot(found.position[0] - truth[0], found.position[1] - truth[1]),
                    found.evaluations,
                    time.perf_counter() - started,
                )
            )
        rows.append(result)
    rows = np.array(rows)
    for index, label in enumerate(("pyramidal", "exhaustive")):
        print(
            f"{label:10s}: error max {100 * rows[:, index, 0].max():.2f} cm, "
            f"mean {100 * rows[:, index, 0].mean():.2f} cm; "
            f"evaluations {rows[:, index, 1].mean():,.0f}; time {1e3 * rows[:, index, 2].mean():.2f} ms"
        )
    print(
        f"ratio exhaustive / pyramidal: {rows[:, 1, 1].mean() / rows[:, 0, 1].mean():,.0f}x evaluations, "
        f"{rows[:, 1, 2].mean() / rows[:, 0, 2].mean():,.0f}x time"
    )


COMPARISON_STARTS = ((-1.5, -1.0, 0.0), (1.0, -0.5, 2.0), (-1.0, 0.8, -1.0), (1.5, 0.0, 3.0), (0.5, -1.1, 1.0))
"""open_room poses clear of the walls, the pillar and the table; the first is the world's start."""


class _BeaconLocalizerRun:
    """The beacon_localizer node's logic without ROS: localized while the ranges fit the pose within threshold."""

    def __init__(self, beacons) -> None:
        self.localizer = BeaconLocalizer(beacons, BeaconLocalizerConfig())  # initial pose (0, 0, 0): unknown

    def update(self, odometry, scan, reading: BeaconReading):
        self.localizer.update(odometry, reading.ranges, reading.compass)
        pose = self.localizer.pose
        return pose, self.localizer.mismatch(pose, reading) <= self.localizer.config.threshold


class _FilterRun:
    def __init__(self, grid, beacons, seed: int, use_scan: bool, use_beacons: bool) -> None:
        self.pf = ParticleFilter(
            grid,
            ParticleFilterConfig(seed=seed),
            beacons=beacons if use_beacons else None,
        )
        self.use_scan, self.use_beacons = use_scan, use_beacons

    def update(self, odometry, scan, reading: BeaconReading):
        estimate = self.pf.update(
            odometry, scan if self.use_scan else None, beacons=reading if self.use_beacons else None
        )
        return (estimate.pose.x, estimate.pose.y, estimate.pose.theta), estimate.localized


def beacon_comparison_run(world: World, start, seed: int, seconds: float) -> dict:
    """One wall-following drive from `start`; every localizer gets the same observation each step
    (odometry, scan, one beacon reading). Returns name -> (t, localized, position error, heading error, cpu s)."""
    sim = Simulator(
        world,
        SimulationConfig(
            dt=FOLLOWER.dt,
            seed=seed,
            start=tuple(start),
            lidar=LidarConfig(noise_std=0.02),
            encoders=EncoderConfig(noise=0.02, slip=0.03),
        ),
    )
    grid = rasterize_world(world, RESOLUTION)
    runs = {
        "beacon localizer": _BeaconLocalizerRun(world.beacons),
        "PF beacons": _FilterRun(grid, world.beacons, seed, use_scan=False, use_beacons=True),
        "PF scan + beacons": _FilterRun(grid, world.beacons, seed, use_scan=True, use_beacons=True),
        "PF scan": _FilterRun(grid, world.beacons, seed, use_scan=True, use_beacons=False),
    }
    traces = {name: ([], [], [], [], []) for name in runs}
    follower = WallFollower(FOLLOWER)
    while sim.time < seconds:
        odometry, scan = tuple(sim.odom_pose), scan_of(sim)
        positions, ranges, compass = sim.beacon_reading()
        reading = BeaconReading.checked(ranges, compass, len(positions))
        truth = sim.pose
        for name, localizer in runs.items():
            started = time.process_time()
            pose, localized = localizer.update(odometry, scan, reading)
            cpu = time.process_time() - started
            for values, value in zip(
                traces[name],
                (
                    sim.time,
                    localized,
                    math.hypot(pose[0] - truth.x, pose[1] - truth.y),
                    abs(float(wrap_angle(pose[2] - truth.theta))),
                    cpu,
                ),
                strict=True,
            ):
                values.append(value)
        command = follower.compute(scan, *sim.odom_twist, sim.time)
        sim.step(command.v, command.w)
    return {name: tuple(np.array(v) for v in values) for name, values in traces.items()}


def bench_beacon_comparison(starts: int, seconds: float) -> None:
    world = load_world(WORLDS / "open_room.yaml")
    print(
        f"== beacon world ({world.name}, {len(world.beacons)} beacons near the corners): one wall-following drive "
        f"of {seconds:.0f} s per start, the same observations to each localizer; LiDAR noise 0.02 m, encoder "
        "noise 0.02, slip 0.03, beacon range noise 0.01 m, compass 0.01 rad; none knows the start"
    )
    warm = Simulator(world, SimulationConfig())  # compile the likelihood kernel outside the timed steps
    _FilterRun(rasterize_world(world, RESOLUTION), world.beacons, 0, True, True).update(
        tuple(warm.odom_pose), scan_of(warm), BeaconReading.checked(warm.beacon_reading()[1], 0.0, len(world.beacons))
    )
    results: dict[str, list] = {}
    for seed, start in enumerate(COMPARISON_STARTS[:starts]):
        for name, (t, localized, position, heading, cpu) in beacon_comparison_run(world, start, seed, seconds).items():
            index = np.flatnonzero(localized)
            row = {"cpu": float(np.mean(cpu)), "cpu_max": float(cpu.max())}
            if index.size:
                first = int(index[0])
                row.update(
                    time=t[first],
                    error=position[first],
                    heading=math.degrees(heading[first]),
                    rms=float(np.sqrt(np.mean(position[first:] ** 2))),
                    rms_heading=math.degrees(float(np.sqrt(np.mean(heading[first:] ** 2)))),
                    kept=float(np.mean(localized[first:])),
                )
                print(
                    f"start {start}  {name:18s} localized at {row['time']:5.2f} s  error {100 * row['error']:5.2f} cm "
                    f"{row['heading']:4.2f} deg  RMS after {100 * row['rms']:5.2f} cm {row['rms_heading']:4.2f} deg  "
                    f"localized {100 * row['kept']:5.1f} % after  "
                    f"CPU {1e3 * row['cpu']:.2f} ms (max {1e3 * row['cpu_max']:.1f})"
                )
            else:
                print(
                    f"start {start}  {name:18s} never localized  "
                    f"CPU {1e3 * row['cpu']:.2f} ms (max {1e3 * row['cpu_max']:.1f})"
                )
            results.setdefault(name, []).append(row)
    print(
        f"summary over {starts} starts (first declaration: median, max; error at it: max; RMS from it on: worst; "
        "CPU per observation: mean, worst single one)"
    )
    for name, rows in results.items():
        done = [r for r in rows if "time" in r]
        if not done:
            print(f"{name:18s} never localized")
            continue
        times = [r["time"] for r in done]
        print(
            f"{name:18s} localized {len(done)}/{len(rows)}  at {np.median(times):5.2f} s (max {max(times):5.2f})  "
            f"error max {100 * max(r['error'] for r in done):5.2f} cm {max(r['heading'] for r in done):4.2f} deg  "
            f"RMS worst {100 * max(r['rms'] for r in done):5.2f} cm {max(r['rms_heading'] for r in done):4.2f} deg  "
            f"localized after >= {100 * min(r['kept'] for r in done):5.1f} %  "
            f"CPU {1e3 * np.mean([r['cpu'] for r in rows]):.2f} ms (max {1e3 * max(r['cpu_max'] for r in rows):.1f})"
        )


CROWDED_FAMILIES = ("open_room", "pillars", "loops", "perfect")


def _crowded_case(args) -> dict:
    from amr_control.wall_follower_config import WallFollowerConfig
    from amr_evaluation.crowded_localization import crowded_world, figures, run_crowded
    from amr_localization.particle_filter_parameters import config_of
    from amr_maps.maze_families import generate

    family, seed, others, mode, noise, known, seconds, overrides = args
    base = generate(family, seed, width=0.7)
    world = crowded_world(base, others, seed)
    mode = "stand" if mode == "alone" else mode
    params = {**PARAMETERS["particle_filter"], "seed": seed, **overrides}
    follower = WallFollowerConfig.from_params(dict(PARAMETERS["wall_follower"]))
    started = time.perf_counter()
    trace = run_crowded(
        world,
        config_of(params),
        follower,
        seconds,
        mode=mode,
        lidar_noise=noise,
        seed=seed,
        known_start=known,
        range_max=params.get("laser_max_range"),
        resolution=params["map_resolution"],
    )
    return {
        "case": args,
        "figures": figures(trace),
        "wall": time.perf_counter() - started,
        "collisions": trace.robot_collisions,
    }


def bench_crowded(seeds: int, jobs: int, seconds: float, known: bool, overrides: dict | None = None) -> list[dict]:
    """The ego's filter among 1-5 other robots: generated rooms and mazes (corridors 0.7 m), other robots placed
    0.3-1.2 m from its start, standing or wall following, LiDAR noise 0.01-0.03 m."""
    from concurrent.futures import ProcessPoolExecutor

    rng = np.random.default_rng(22)
    cases = []
    for seed in range(seeds):
        for family in CROWDED_FAMILIES:
            for mode in ("stand", "drive"):
                others = int(rng.integers(1, 6))
                noise = float(rng.uniform(0.01, 0.03))
                cases.append((family, seed, others, mode, noise, known, seconds, dict(overrides or {})))
            # the control: the same world and start, no other robot (what the world alone does to the filter)
            cases.append((family, seed, 0, "alone", noise, known, seconds, dict(overrides or {})))
    what = "tracking from the true start" if known else "global localization (particles spread over the map)"
    print(
        f"== crowded scans: {what}, {seconds:.0f} s, {len(cases)} runs: {', '.join(CROWDED_FAMILIES)} "
        f"x {seeds} seeds x stand/drive (and alone: the control), 1-5 other robots 0.3-1.2 m from the start, "
        f"LiDAR noise 0.01-0.03 m, encoder noise 0.01, slip 0.02"
        + (f"; filter overrides {overrides}" if overrides else "")
    )
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        results = list(pool.map(_crowded_case, cases))
    for result in results:
        family, seed, others, mode, noise, *_ = result["case"]
        f = result["figures"]
        head = f"{family:>9s} s{seed} {others} {mode:5s} noise {noise:.3f}"
        occluded = f"beams on robots mean {100 * f.occluded_mean:4.1f} % max {100 * f.occluded_max:4.1f} %"
        if f.first_localized is None:
            print(f"{head}  never localized  {occluded}  wall {result['wall']:5.1f} s")
            continue
        print(
            f"{head}  localized at {f.first_localized:5.1f} s  max err {100 * f.max_error[0]:5.1f} cm "
            f"{f.max_error[1]:5.1f} deg  RMS {100 * f.rms[0]:4.1f} cm {f.rms[1]:4.2f} deg  "
            f"kept {100 * f.localized_share:5.1f} %"
            f"  withdrawals {f.withdrawals}  false {f.false_localized}  {occluded}  wall {result['wall']:5.1f} s"
        )
    alone = [r["figures"] for r in results if r["case"][3] == "alone"]
    results = [r for r in results if r["case"][3] != "alone"]
    print(
        f"controls without other robots: localized {sum(f.first_localized is not None for f in alone)}/{len(alone)}, "
        f"steps falsely localized {sum(f.false_localized for f in alone)}"
    )
    done = [r["figures"] for r in results if r["figures"].first_localized is not None]
    print(
        f"localized: {len(done)}/{len(results)}; within 60 s: {sum(f.first_localized <= 60 for f in done)}; "
        f"every localized step within 10 cm / 10 deg: {sum(f.tracking_within for f in done)}/{len(done)}; "
        f"steps falsely localized: {sum(f.false_localized for f in (r['figures'] for r in results))}"
    )
    if done:
        print(
            f"worst error while localized {100 * max(f.max_error[0] for f in done):.1f} cm, "
            f"{max(f.max_error[1] for f in done):.1f} deg; worst RMS {100 * max(f.rms[0] for f in done):.1f} cm, "
            f"{max(f.rms[1] for f in done):.2f} deg; localized share after the first declaration: min "
            f"{100 * min(f.localized_share for f in done):.1f} %, withdrawals {sum(f.withdrawals for f in done)}"
        )
    print(
        f"beams on other robots: mean of runs {100 * np.mean([r['figures'].occluded_mean for r in results]):.1f} %, "
        f"largest in a step {100 * max(r['figures'].occluded_max for r in results):.1f} %"
    )
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer runs")
    parser.add_argument(
        "--beacon-comparison",
        action="store_true",
        help="only the beacon world comparison (beacon localizer vs particle filter)",
    )
    parser.add_argument("--jobs", type=int, default=2, help="local processes for the sweeps (default 2)")
    parser.add_argument("--scheduler", help="a Dask scheduler address (tcp://host:8786) for the sweeps")
    parser.add_argument("--results", help="the sweeps' records file (JSON lines): kept, and a run resumes from it")
    parser.add_argument("--sweeps-only", action="store_true", help="only the sweeps (symmetric, kidnapping, global)")
    parser.add_argument(
        "--symmetry",
        action="store_true",
        help="only the rooms whose symmetry one feature breaks, and the truly symmetric controls",
    )
    parser.add_argument(
        "--seeds",
        type=int,
        help="--symmetry: seeds per family (default 10, --quick 2); --crowded: "
        "seeds per family and mode (default 3, --quick 1)",
    )
    parser.add_argument(
        "--control-seeds", type=int, help="--symmetry: seeds per symmetric control (default 2, --quick 1)"
    )
    parser.add_argument(
        "--crowded",
        action="store_true",
        help="only the robot localizing among other robots: tracking and global",
    )
    parser.add_argument("--seconds", type=float, help="--crowded: simulated s per run (default 90, --quick 40)")
    args = parser.parse_args()
    quick = args.quick
    if args.crowded:
        seeds, seconds = args.seeds or (1 if quick else 3), args.seconds or (40.0 if quick else 90.0)
        bench_crowded(seeds, args.jobs, seconds, known=True)
        bench_crowded(seeds, args.jobs, seconds, known=False)
        return
    if args.symmetry:
        seeds = args.seeds or (2 if quick else 10)
        bench_symmetry(
            Sweep(args.jobs, args.scheduler, args.results),
            seeds=seeds,
            seconds=240.0,
            control_seeds=args.control_seeds or (1 if quick else 2),
            control_seconds=120.0 if quick else 300.0,
        )
        return
    if args.beacon_comparison:
        bench_beacon_comparison(starts=3 if quick else len(COMPARISON_STARTS), seconds=60.0)
        return
    sweep = Sweep(args.jobs, args.scheduler, args.results)
    if not args.sweeps_only:
        bench_update_cost(repeats=20 if quick else 50)
        bench_beacons(cases=5 if quick else 20)
    bench_symmetric(sweep, seeds=2 if quick else 5, seconds=60.0 if quick else 120.0)
    bench_kidnap(sweep, seeds=1 if quick else 3)
    bench_global(sweep, seeds=1 if quick else 3, mazes=4 if quick else 16, seconds=90.0)
    if args.sweeps_only:
        return
    bench_beacon_comparison(starts=3 if quick else len(COMPARISON_STARTS), seconds=60.0)


if __name__ == "__main__":
    main()
