"""CARMEN laser logs (the Radish data sets: intel, aces, fhw, orebro, ...) read into ScanData and poses.

A CARMEN log is text (plain or gzip), one message a line, its type first. The scans come from one message type:

    FLASER n r_1 ... r_n x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
    RLASER (the rear laser, the same fields)
    ROBOTLASER1 laser_type start_angle fov resolution max_range accuracy remission_mode
                n r_1 ... r_n m e_1 ... e_m laser_x laser_y laser_theta robot_x robot_y robot_theta
                tv rv forward_safety side_safety turn_axis timestamp host logger_timestamp
    (ROBOTLASER2: the rear one)

`x y theta` (laser_x ... for ROBOTLASER) is the laser's pose: in a corrected log, the reference trajectory. An
FLASER line may end early: after the pose come, if present, the odometry pose, the timestamp, the host and the
logger's timestamp. FLASER beams start at -fov/2 (fov 180 deg unless a PARAM `..._front_laser_fov` or
`..._frontlaser_fov` says otherwise, in degrees) and are spread evenly: fov / (n - 1) apart for an odd count (181,
361: both ends measured), fov / n for an even one (180, 360). ROBOTLASER lines carry their own angles.

The type read is the first of FLASER, ROBOTLASER1, RLASER, ROBOTLASER2 the log has (or the one asked for); every
other line is a known message of another kind (ODOM, NEFF, PARAM, SYNC, TRUEPOS, RAWLASER1-4 (no pose), ...: any
word of capitals, digits and underscores) and is counted in `CarmenLog.ignored`, blank lines and lines starting
with `#` are skipped, and anything else (a first word that is no message type, a scan line with too few or
non-numeric fields, a NaN, a negative range, a count that disagrees) is a DatasetError naming the file, the line
number and what is wrong.

No return: a laser reports its maximum range (81.83 m for intel, 50 m for aces, 51.05-51.1 m for fhw,
32.759-32.767 m for orebro). `detect_max_range` finds it per log as the largest value that repeats many times,
with the values repeated as often just below it (0.1 m + 0.2 %), provided it stands out from the readings below
it (at least MAX_RANGE_SPIKE times the most frequent value there); readings at or above it become +inf (REP
117), a reading of 0 (nothing measured) -inf, and `range_max` of every scan is that maximum range (or, without
one, the largest reading of the log).

Timestamps: `has_stamps` is True when every scan has one, they are not all equal and at most 10 % of them fail to
increase (intel: 4 of 910 go back by up to 0.86 s); those are spread evenly between their neighbours, so the
stamps strictly increase. Otherwise (orebro: all 0) the stamps are synthesized 1 s apart from 0. `stamp_problem` says
what was done.
"""

from __future__ import annotations

import gzip
import itertools
import math
import re
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from amr_util.geometry import Pose2D, wrap_angle
from amr_util.scan import ScanData

SCAN_TYPES = ("FLASER", "ROBOTLASER1", "RLASER", "ROBOTLASER2")
"""Message types that carry a scan and the laser's pose, in the order of preference."""
MESSAGE_TYPE = re.compile(r"^[A-Z][A-Z0-9_]*$")
"""What a CARMEN message type looks like: a line starting with one is read or ignored, never an error."""
SYNTHETIC_PERIOD = 1.0
"""s between synthesized stamps when the log has none."""
MAX_STAMP_REPAIRS = 0.1
"""More stamps than this fraction not increasing: the stamps are not used, but synthesized."""
MAX_RANGE_REPEATS = 1e-4
"""A maximum-range value repeats in at least this fraction of all readings (and at least 3 times)."""
MAX_RANGE_SPIKE = 10.0
"""... and at least this many times as often as the most frequent value in the 10 % below it."""
DEFAULT_FOV = math.pi
LOG_MOUNT = {"lidar_x": 0.0, "lidar_y": 0.0, "lidar_yaw": 0.0}
"""The LiDAR mount of a filter or a SLAM fed a log: its poses are the laser's, so the scans are taken at them (not at
the robot description's mount)."""


class DatasetError(ValueError):
    """A log that cannot be read: the message names the file, the line (when one is at fault) and the problem."""


@dataclass(frozen=True)
class LogScan:
    """One scan of a log: when, what, and where the laser was."""

    stamp: float
    """s; synthesized (SYNTHETIC_PERIOD apart) when the log has no usable stamps."""
    scan: ScanData
    """ranges in m (+inf: no return, -inf: a reading of 0), angles in rad."""
    pose: Pose2D
    """The laser's (corrected) pose in the log's frame: (x, y, theta)."""
    odom: Pose2D | None = None
    """The odometry pose the line carries (FLASER odom_*, ROBOTLASER robot_*), if any; a corrected log repeats the
    corrected pose there."""
    line: int = 0
    """Its line number in the file (1-based)."""


@dataclass(frozen=True)
class CarmenLog:
    """A log read by read_carmen."""

    path: Path
    scans: list[LogScan]
    has_stamps: bool
    max_range: float | None
    """Readings at or above it were no return (+inf); None: the log has none that could be told apart."""
    message: str
    """The message type the scans came from."""
    stamp_problem: str = ""
    """Why the stamps were synthesized, or which were repaired ('' when the log's stamps are used as they are)."""
    ignored: dict[str, int] = field(default_factory=dict)
    """{message type: lines} of the lines not read as scans."""

    def __len__(self) -> int:
        return len(self.scans)

    def poses(self) -> np.ndarray:
        """(N, 3) laser poses."""
        return np.array([scan.pose for scan in self.scans], dtype=float).reshape(-1, 3)

    def stamps(self) -> np.ndarray:
        """(N,) stamps, s."""
        return np.array([scan.stamp for scan in self.scans], dtype=float)


@dataclass
class _Raw:
    """A scan line as parsed, before the log-wide decisions (maximum range, stamps)."""

    line: int
    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    pose: Pose2D
    odom: Pose2D | None
    stamp: float | None
    max_range: float | None = None
    """The line's own maximum range (ROBOTLASER), if it states one."""


def played_backwards(log: CarmenLog) -> CarmenLog:
    """The log's scans in reverse order, their stamps mirrored (first + last - stamp: still growing): the same building
    on another path, the laser facing away from the way the robot drives; a proxy for logs not seen."""
    if not log.scans:
        return log
    first, last = log.scans[0].stamp, log.scans[-1].stamp
    return replace(log, scans=[replace(item, stamp=first + last - item.stamp) for item in reversed(log.scans)])


def thinned(log: CarmenLog, stride: int) -> CarmenLog:
    """Every stride-th scan of the log (keyframes farther apart)."""
    if int(stride) < 1:
        raise DatasetError(f"{log.path}: stride must be at least 1, got {stride!r}")
    return replace(log, scans=log.scans[:: int(stride)])


def log_name(path: Path) -> str:
    """A log's name: its file name's first word (intel-corrected.log.gz: intel; orebro.log: orebro)."""
    return Path(path).name.split("-")[0].split(".")[0]


def open_text(path: Path):
    """The file as text lines, gunzipped when it is gzip (by its magic bytes, whatever its name)."""
    with open(path, "rb") as probe:
        magic = probe.read(2)
    if magic == b"\x1f\x8b":
        return gzip.open(path, "rt", encoding="utf-8", errors="replace")
    return open(path, encoding="utf-8", errors="replace")


def read_carmen(
    path: str | Path, *, message: str | None = None, max_range: float | None = None, fov: float | None = None
) -> CarmenLog:
    """Every scan of a CARMEN log (plain or gzip).

    message: the scan type to read (one of SCAN_TYPES; None: the first of them the log has).
    max_range: readings at or above it are no return (None: detect_max_range finds it; math.inf: none).
    fov: FLASER/RLASER field of view in rad (None: the log's PARAM, else 180 deg).
    """
    path = Path(path)
    if message is not None and message not in SCAN_TYPES:
        raise DatasetError(f"{path}: message {message!r}: not a scan type (one of {', '.join(SCAN_TYPES)})")
    if not path.is_file():
        raise DatasetError(f"{path}: no such file")
    raws: dict[str, list[_Raw]] = {kind: [] for kind in SCAN_TYPES}
    ignored: Counter[str] = Counter()
    params: dict[str, str] = {}
    try:
        with open_text(path) as lines:
            for number, line in enumerate(lines, start=1):
                parts = line.split()
                if not parts or parts[0].startswith("#"):
                    continue
                kind = parts[0]
                if kind in raws and (message is None or kind == message):
                    raws[kind].append(_parse_scan(parts, path, number, fov, params))
                elif MESSAGE_TYPE.match(kind):
                    ignored[kind] += 1
                    if kind == "PARAM" and len(parts) >= 3:
                        params[parts[1]] = parts[2]
                else:
                    raise DatasetError(
                        f"{path}:{number}: {_show(kind)}: not a CARMEN message type "
                        f"(a line starts with one, such as FLASER, ODOM or PARAM)"
                    )
    except OSError as error:
        raise DatasetError(f"{path}: cannot read ({error})") from error
    except EOFError as error:
        raise DatasetError(f"{path}: the gzip stream ends early ({error})") from error
    chosen = message or next((kind for kind in SCAN_TYPES if raws[kind]), None)
    if chosen is None or not raws[chosen]:
        found = ", ".join(f"{kind} {count}" for kind, count in sorted(ignored.items())) or "nothing"
        wanted = message or " or ".join(SCAN_TYPES)
        raise DatasetError(f"{path}: no {wanted} line (found: {found})")
    for kind in SCAN_TYPES:
        if kind != chosen and raws[kind]:
            ignored[kind] += len(raws[kind])
    scans = raws[chosen]
    if max_range is None:
        stated = [raw.max_range for raw in scans if raw.max_range is not None]
        max_range = detect_max_range(np.concatenate([raw.ranges for raw in scans]))
        if max_range is None and stated:
            max_range = min(stated)
    elif not (max_range > 0.0):
        raise DatasetError(f"{path}: max_range must be positive (math.inf: none), got {max_range!r}")
    elif math.isinf(max_range):
        max_range = None
    stamps, has_stamps, problem = _stamps(scans, path)
    bound = max_range if max_range is not None else _largest_reading(scans)
    return CarmenLog(
        path,
        [_log_scan(raw, stamp, max_range, bound) for raw, stamp in zip(scans, stamps, strict=True)],
        has_stamps=has_stamps,
        max_range=max_range,
        message=chosen,
        stamp_problem=problem,
        ignored=dict(sorted(ignored.items())),
    )


def detect_max_range(ranges: np.ndarray) -> float | None:
    """The log's no-return value: the lowest of the values that repeat at least max(3, MAX_RANGE_REPEATS of all)
    times within 0.1 m + 0.2 % below the largest such value, when their count stands out (MAX_RANGE_SPIKE times)
    from every value within 10 % below them; None when no value does."""
    ranges = np.asarray(ranges, dtype=float)
    ranges = ranges[np.isfinite(ranges) & (ranges > 0.0)]
    if ranges.size == 0:
        return None
    values, counts = np.unique(ranges, return_counts=True)
    enough = max(3, math.ceil(MAX_RANGE_REPEATS * ranges.size))
    repeated = np.flatnonzero(counts >= enough)
    if repeated.size == 0:
        return None
    top = values[repeated[-1]]
    window = 0.1 + 0.002 * top
    members = repeated[values[repeated] >= top - window]
    lowest = values[members[0]]
    below = (values < lowest) & (values >= lowest - 0.1 * top)
    background = counts[below].max() if below.any() else 1
    if counts[members].sum() < MAX_RANGE_SPIKE * background:
        return None
    return float(lowest)


def _show(text: str) -> str:
    return repr(text if len(text) <= 40 else text[:40] + "...")


def _numbers(parts: list[str], first: int, count: int, path: Path, number: int, what: str) -> np.ndarray:
    chunk = parts[first : first + count]
    if len(chunk) < count:
        raise DatasetError(f"{path}:{number}: {parts[0]}: {what}: expected {count} values, the line has {len(chunk)}")
    try:
        values = np.array(chunk, dtype=float)
    except ValueError:
        bad = next(word for word in chunk if not _is_number(word))
        raise DatasetError(f"{path}:{number}: {parts[0]}: {what}: {_show(bad)} is not a number") from None
    if np.isnan(values).any():
        raise DatasetError(f"{path}:{number}: {parts[0]}: {what}: NaN")
    return values


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def _count(parts: list[str], index: int, path: Path, number: int, what: str) -> int:
    word = parts[index] if index < len(parts) else ""
    if not word.isdigit() or int(word) == 0:
        raise DatasetError(f"{path}:{number}: {parts[0]}: {what}: expected a positive integer, got {_show(word)}")
    return int(word)


def _pose(values: np.ndarray, path: Path, number: int, kind: str, what: str) -> Pose2D:
    if not np.isfinite(values).all():
        raise DatasetError(f"{path}:{number}: {kind}: {what} is not finite: {values.tolist()}")
    return Pose2D(float(values[0]), float(values[1]), float(wrap_angle(float(values[2]))))


def _ranges(values: np.ndarray, path: Path, number: int, kind: str) -> np.ndarray:
    if (values < 0.0).any():
        raise DatasetError(f"{path}:{number}: {kind}: negative range {values[values < 0.0][0]:g}")
    return values


def _stamp(parts: list[str], index: int, path: Path, number: int) -> float | None:
    if index >= len(parts):
        return None
    try:
        stamp = float(parts[index])
    except ValueError:
        raise DatasetError(f"{path}:{number}: {parts[0]}: timestamp {_show(parts[index])} is not a number") from None
    if not math.isfinite(stamp):
        raise DatasetError(f"{path}:{number}: {parts[0]}: timestamp {parts[index]} is not finite")
    return stamp


def _fov(params: dict[str, str], kind: str, given: float | None) -> float:
    """The field of view of an FLASER/RLASER line (rad): given, else the log's PARAM (degrees), else 180 deg."""
    if given is not None:
        return given
    side = "front" if kind == "FLASER" else "rear"
    for name in (f"laser_{side}_laser_fov", f"laser_{side}laser_fov", f"robot_{side}_laser_fov"):
        if name in params:
            try:
                degrees = float(params[name])
            except ValueError:
                continue
            if 0.0 < degrees <= 360.0:
                return math.radians(degrees)
    return DEFAULT_FOV


def _parse_scan(parts: list[str], path: Path, number: int, fov: float | None, params: dict[str, str]) -> _Raw:
    kind = parts[0]
    if kind.startswith("ROBOTLASER"):
        return _parse_robot_laser(parts, path, number)
    n = _count(parts, 1, path, number, "beam count")
    ranges = _ranges(_numbers(parts, 2, n, path, number, f"{n} ranges"), path, number, kind)
    rest = len(parts) - 2 - n
    if rest < 3:
        raise DatasetError(
            f"{path}:{number}: {kind}: expected x y theta after the {n} ranges, the line has {rest} "
            f"values there (is the beam count {n} right?)"
        )
    pose = _pose(_numbers(parts, 2 + n, 3, path, number, "pose"), path, number, kind, "the pose")
    odom, stamp_index = None, 2 + n + 3
    if rest >= 6:
        odom = _pose(_numbers(parts, 2 + n + 3, 3, path, number, "odometry pose"), path, number, kind, "odometry")
        stamp_index += 3
    angle_fov = _fov(params, kind, fov)
    increment = angle_fov / (n - 1) if n % 2 == 1 and n > 1 else angle_fov / n
    return _Raw(number, ranges, -0.5 * angle_fov, increment, pose, odom, _stamp(parts, stamp_index, path, number))


def _parse_robot_laser(parts: list[str], path: Path, number: int) -> _Raw:
    kind = parts[0]
    head = _numbers(
        parts, 1, 7, path, number, "laser_type start_angle fov resolution max_range accuracy remission_mode"
    )
    _, start, fov, resolution, stated_max = head[:5]
    n = _count(parts, 8, path, number, "beam count")
    ranges = _ranges(_numbers(parts, 9, n, path, number, f"{n} ranges"), path, number, kind)
    remissions = int(_numbers(parts, 9 + n, 1, path, number, "remission count")[0])
    if remissions < 0:
        raise DatasetError(f"{path}:{number}: {kind}: negative remission count {remissions}")
    at = 10 + n + remissions
    poses = _numbers(parts, at, 6, path, number, "laser and robot poses")
    pose = _pose(poses[:3], path, number, kind, "the laser pose")
    odom = _pose(poses[3:], path, number, kind, "the robot pose")
    if not (math.isfinite(start) and math.isfinite(fov)):
        raise DatasetError(f"{path}:{number}: {kind}: start_angle and fov must be finite")
    if not (math.isfinite(resolution) and resolution > 0.0):
        resolution = fov / (n - 1) if n > 1 else fov
    max_range = float(stated_max) if math.isfinite(stated_max) and stated_max > 0.0 else None
    return _Raw(
        number, ranges, float(start), float(resolution), pose, odom, _stamp(parts, at + 11, path, number), max_range
    )


def _stamps(scans: list[_Raw], path: Path) -> tuple[list[float], bool, str]:
    """The scans' stamps, whether they are the log's, and what was done to them ('' when nothing)."""
    missing = next((raw.line for raw in scans if raw.stamp is None), None)
    if missing is not None:
        problem = f"no timestamp on line {missing}"
    else:
        stamps = [raw.stamp for raw in scans]
        back = [b.line for a, b in itertools.pairwise(scans) if not b.stamp > a.stamp]
        if len(scans) > 1 and all(stamp == stamps[0] for stamp in stamps):
            problem = f"every timestamp is {stamps[0]:g}"
        elif len(back) > MAX_STAMP_REPAIRS * len(scans):
            problem = f"{len(back)} timestamps do not increase (the first on line {back[0]})"
        else:
            if not back:
                return stamps, True, ""
            lines = ", ".join(map(str, back[:5])) + (", ..." if len(back) > 5 else "")
            return (
                _spread(stamps),
                True,
                (f"{len(back)} timestamps did not increase (lines {lines}): spread evenly between their neighbours"),
            )
    return (
        [SYNTHETIC_PERIOD * i for i in range(len(scans))],
        False,
        problem + f": stamps synthesized {SYNTHETIC_PERIOD:g} s apart",
    )


def _spread(stamps: list[float]) -> list[float]:
    """The stamps with each run that does not increase past the stamp before it spread evenly between that stamp
    and the next one that does (after the last: the median period apart), so that they strictly increase."""
    stamps = list(stamps)
    steps = np.diff(stamps)
    period = float(np.median(steps[steps > 0.0])) if (steps > 0.0).any() else SYNTHETIC_PERIOD
    i = 1
    while i < len(stamps):
        if stamps[i] > stamps[i - 1]:
            i += 1
            continue
        j = next((k for k in range(i + 1, len(stamps)) if stamps[k] > stamps[i - 1]), None)
        end = stamps[j] if j is not None else stamps[i - 1] + period * (len(stamps) - i + 1)
        last = j if j is not None else len(stamps)
        for k in range(i, last):
            stamps[k] = stamps[i - 1] + (end - stamps[i - 1]) * (k - i + 1) / (last - i + 1)
        i = last
    return stamps


def _largest_reading(scans: list[_Raw]) -> float:
    largest = max(float(raw.ranges.max(initial=0.0)) for raw in scans)
    return largest if largest > 0.0 else 1.0


def _log_scan(raw: _Raw, stamp: float, max_range: float | None, bound: float) -> LogScan:
    ranges = raw.ranges.copy()
    if max_range is not None:
        ranges[ranges >= max_range] = math.inf
    ranges[ranges == 0.0] = -math.inf
    scan = ScanData(ranges, raw.angle_min, raw.angle_increment, 0.0, bound)
    return LogScan(float(stamp), scan, raw.pose, raw.odom, raw.line)
