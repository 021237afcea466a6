"""A sweep's figures (matplotlib, Agg: no display needed), written beside its results file.

- ``<stem>.success.png``: goal success rate per family, one bar per controller and config;
- ``<stem>.time_to_goal.png``: time-to-goal distributions (box and points) per family and config;
- ``<stem>.localization.png``: time to the first localized declaration and the error then, per family
  and config (only when some episode localizes).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def _runs(records: Iterable[dict[str, Any]]) -> tuple[list[str], list[str], list[dict]]:
    kept = [r for r in records if r.get("error") is None]
    families = sorted({r["family"] for r in kept})
    configs = sorted({f"{r['controller']} {r['config']}" for r in kept})
    return families, configs, kept


def _grouped_axes(count: int):
    figure, axes = plt.subplots(figsize=(max(6.0, 0.9 * count + 2.5), 4.2))
    return figure, axes


def success_plot(records: Iterable[dict[str, Any]], path: Path) -> Path | None:
    families, configs, kept = _runs(records)
    cells: dict[tuple[str, str], list[bool]] = defaultdict(list)
    for r in kept:
        if r.get("goal_reached") is not None:
            cells[(r["family"], f"{r['controller']} {r['config']}")].append(bool(r["goal_reached"]))
    if not cells:
        return None
    figure, axes = _grouped_axes(len(families))
    width = 0.8 / max(len(configs), 1)
    x = np.arange(len(families))
    for index, config in enumerate(configs):
        rates = [100 * np.mean(cells[(f, config)]) if cells.get((f, config)) else np.nan for f in families]
        counts = [len(cells.get((f, config), [])) for f in families]
        bars = axes.bar(x + (index - (len(configs) - 1) / 2) * width, rates, width, label=config)
        for bar, count, rate in zip(bars, counts, rates, strict=True):
            if count:
                axes.annotate(
                    f"{int(round(rate * count / 100))}/{count}",
                    (bar.get_x() + bar.get_width() / 2, bar.get_height()),
                    ha="center",
                    va="bottom",
                    fontsize=7,
                )
    axes.set_xticks(x, families, rotation=30, ha="right")
    axes.set_ylabel("goal reached (%)")
    axes.set_ylim(0, 110)
    axes.set_title("Success rate per family and configuration")
    axes.legend(fontsize=8, loc="lower right")
    return _save(figure, path)


def time_to_goal_plot(records: Iterable[dict[str, Any]], path: Path) -> Path | None:
    families, configs, kept = _runs(records)
    cells: dict[tuple[str, str], list[float]] = defaultdict(list)
    for r in kept:
        if r.get("goal_reached") and r.get("time_to_goal") is not None:
            cells[(r["family"], f"{r['controller']} {r['config']}")].append(float(r["time_to_goal"]))
    if not cells:
        return None
    figure, axes = _grouped_axes(len(families))
    width = 0.8 / max(len(configs), 1)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for index, config in enumerate(configs):
        offset = (index - (len(configs) - 1) / 2) * width
        data = [(i + offset, cells[(f, config)]) for i, f in enumerate(families) if cells.get((f, config))]
        if not data:
            continue
        colour = colours[index % len(colours)]
        axes.boxplot(
            [d for _, d in data],
            positions=[p for p, _ in data],
            widths=width * 0.8,
            showfliers=False,
            patch_artist=True,
            boxprops={"facecolor": colour, "alpha": 0.35},
            medianprops={"color": colour},
        )
        for position, values in data:
            jitter = np.linspace(-width * 0.25, width * 0.25, len(values)) if len(values) > 1 else [0.0]
            axes.scatter(
                position + np.asarray(jitter),
                values,
                s=8,
                color=colour,
                zorder=3,
                label=config if position == data[0][0] else None,
            )
    axes.set_xticks(np.arange(len(families)), families, rotation=30, ha="right")
    axes.set_xlim(-0.6, len(families) - 0.4)
    axes.set_ylabel("time to goal (s, simulated)")
    axes.set_title("Time to goal (episodes that reached it)")
    axes.legend(fontsize=8)
    return _save(figure, path)


def localization_plot(records: Iterable[dict[str, Any]], path: Path) -> Path | None:
    _, _, kept = _runs(records)
    localized = [r for r in kept if r.get("time_to_localized") is not None]
    if not localized:
        return None
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    groups: dict[str, list[dict]] = defaultdict(list)
    for r in localized:
        groups[f"{r['controller']} {r['config']}\n{r['family']}"].append(r)
    labels = sorted(groups)
    left.boxplot([[r["time_to_localized"] for r in groups[k]] for k in labels], showfliers=True)
    left.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=30, ha="right", fontsize=7)
    left.set_ylabel("time to localized (s)")
    left.set_title("First localized declaration")
    at_first = [
        [
            100
            * (
                r.get("localization_error")
                if r.get("localization_error") is not None
                else r.get("localization_error_max") or 0.0
            )
            for r in groups[k]
        ]
        for k in labels
    ]
    right.boxplot(at_first, showfliers=True)
    right.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=30, ha="right", fontsize=7)
    right.set_ylabel("position error (cm)")
    right.set_title("Localization error (at the first declaration;\nnavigation: largest while localized)")
    return _save(figure, path)


def write_plots(records: list[dict[str, Any]], results: str | Path) -> list[Path]:
    """Every figure that has data, as <results stem>.<figure>.png beside the results file."""
    results = Path(results)
    written = []
    for name, plot in (
        ("success", success_plot),
        ("time_to_goal", time_to_goal_plot),
        ("localization", localization_plot),
    ):
        path = plot(records, results.with_name(f"{results.stem}.{name}.png"))
        if path is not None:
            written.append(path)
    return written


def _save(figure, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
