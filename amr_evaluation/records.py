"""Results files (JSON lines, one record per finished episode, keyed by its spec's hash) and their summary.

A line is written and flushed as soon as its episode finishes, so a killed sweep loses at most the
episodes in flight (what was flushed is the kernel's); the file is fsync'ed at most once a second and when
closed, so a machine that loses power loses at most that second too (an fsync per record cost 6 ms here,
a few % of a 10-second episode). A line cut short is skipped when the file is read again (and the writer
starts on a new line). A record with ``error`` set is not finished: a resumed sweep runs it again.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import time
from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from amr_evaluation.episode import TIMING_FIELDS


def read_records(path: str | Path) -> dict[str, dict[str, Any]]:
    """key -> the last record written for it (a re-run after an error replaces the error)."""
    path = Path(path)
    records: dict[str, dict[str, Any]] = {}
    if not path.exists():
        return records
    with path.open(encoding="utf-8") as stream:
        for line in stream:
            line = line.strip()
            if not line:
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue  # the line a kill cut short
            if isinstance(record, dict) and isinstance(record.get("key"), str):
                records[record["key"]] = record
    return records


def finished(record: dict[str, Any] | None) -> bool:
    return record is not None and record.get("error") is None


class RecordWriter:
    """Appends records to a JSON lines file, one durable line each."""

    def __init__(self, path: str | Path, sync_period: float = 1.0) -> None:
        self.path = Path(path)
        self.sync_period = sync_period
        self._synced = time.monotonic()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._stream = self.path.open("a+", encoding="utf-8")
        self._stream.seek(0, os.SEEK_END)
        if self._stream.tell() > 0:
            self._stream.seek(self._stream.tell() - 1)
            last = self._stream.read(1)
            self._stream.seek(0, os.SEEK_END)
            if last != "\n":
                self._stream.write("\n")  # isolate a line a kill cut short

    def write(self, record: dict[str, Any]) -> None:
        self._stream.write(json.dumps(record, sort_keys=True, allow_nan=False) + "\n")
        self._stream.flush()
        if time.monotonic() - self._synced >= self.sync_period:
            os.fsync(self._stream.fileno())
            self._synced = time.monotonic()

    def close(self) -> None:
        self._stream.flush()
        os.fsync(self._stream.fileno())
        self._stream.close()

    def __enter__(self) -> RecordWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def without_timing(record: dict[str, Any]) -> dict[str, Any]:
    """The record less its wall-clock fields: what must be equal wherever the episode ran."""
    return {k: v for k, v in record.items() if k not in TIMING_FIELDS}


# -- summary ---------------------------------------------------------------------------------------------


def group_key(record: dict[str, Any]) -> tuple[str, str, str]:
    return record["controller"], record["config"], record["family"]


def _median(values: Iterable[float | None]) -> float | None:
    kept = [v for v in values if v is not None and not (isinstance(v, float) and math.isnan(v))]
    return statistics.median(kept) if kept else None


def summarize(records: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (controller, config, family): episodes, goals reached, collisions, stalls, medians."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for record in records:
        groups[group_key(record)].append(record)
    rows = []
    for (controller, config, family), items in sorted(groups.items()):
        ok = [r for r in items if r.get("error") is None]
        with_goal = [r for r in ok if r.get("goal_reached") is not None]
        reached = [r for r in with_goal if r["goal_reached"]]
        localized = [r for r in ok if r.get("time_to_localized") is not None]
        rows.append(
            {
                "controller": controller,
                "config": config,
                "family": family,
                "episodes": len(items),
                "errors": len(items) - len(ok),
                "with_goal": len(with_goal),
                "reached": len(reached),
                "success": len(reached) / len(with_goal) if with_goal else None,
                "time_to_goal": _median(r["time_to_goal"] for r in reached),
                "collisions": sum(r.get("collisions") or 0 for r in ok),
                "collision_free": sum((r.get("collisions") or 0) == 0 for r in ok),
                "stalls": sum(r.get("stalls") or 0 for r in ok),
                "wall_error_run": _median(r.get("wall_error_run") for r in ok),
                "localized": len(localized),
                "time_to_localized": _median(r["time_to_localized"] for r in localized),
                "localization_error": _median(r.get("localization_error") for r in localized),
                "localization_error_max": _median(r.get("localization_error_max") for r in localized),
                "cross_track": _median(r.get("cross_track") for r in ok),
                "wall_time": sum(r.get("wall_time") or 0.0 for r in items),
            }
        )
    return rows


def format_summary(rows: list[dict[str, Any]]) -> str:
    """A plain-text table of summarize()'s rows, and a total line per controller and config."""

    def number(value, scale=1.0, digits=1):
        return "-" if value is None else f"{scale * value:.{digits}f}"

    header = (
        f"{'controller':13s} {'config':14s} {'family':16s} {'runs':>5s} {'goal':>9s} {'t goal':>7s} "
        f"{'coll-free':>9s} {'stalls':>6s} {'wall err':>8s} {'loc':>5s} {'t loc':>6s} {'loc err':>7s} "
        f"{'xte':>5s} {'err':>4s}"
    )
    units = (
        f"{'':13s} {'':14s} {'':16s} {'':>5s} {'':>9s} {'s':>7s} {'':>9s} {'':>6s} {'cm':>8s} {'':>5s} {'s':>6s} "
        f"{'cm':>7s} {'cm':>5s}"
    )
    lines = [header, units.rstrip(), "-" * len(header)]
    totals: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        totals[(row["controller"], row["config"])].append(row)
        goal = f"{row['reached']}/{row['with_goal']}" if row["with_goal"] else "-"
        lines.append(
            f"{row['controller']:13s} {row['config'][:14]:14s} {row['family'][:16]:16s} {row['episodes']:5d} "
            f"{goal:>9s} {number(row['time_to_goal']):>7s} "
            f"{row['collision_free']:4d}/{row['episodes'] - row['errors']:<4d} "
            f"{row['stalls']:6d} {number(row['wall_error_run'], 100, 1):>8s} {row['localized']:5d} "
            f"{number(row['time_to_localized']):>6s} {number(row['localization_error'], 100, 1):>7s} "
            f"{number(row['cross_track'], 100, 2):>5s} {row['errors']:4d}"
        )
    for (controller, config), items in totals.items():
        with_goal = sum(r["with_goal"] for r in items)
        reached = sum(r["reached"] for r in items)
        runs = sum(r["episodes"] for r in items)
        rate = f" ({100 * reached / with_goal:.1f} %)" if with_goal else ""
        lines.append(
            f"TOTAL {controller} {config}: {runs} episodes, goal {reached}/{with_goal}{rate}, "
            f"collision-free {sum(r['collision_free'] for r in items)}, stalls {sum(r['stalls'] for r in items)}, "
            f"errors {sum(r['errors'] for r in items)}, {sum(r['wall_time'] for r in items):.0f} s of episode time"
        )
    lines.append(
        "goal: reached / episodes with a goal; t goal, t loc: median s; wall err: median of the mean |wall "
        "distance - target| over a run; loc err: median error at the first declaration; xte: median of the "
        "mean cross-track error"
    )
    return "\n".join(lines)
