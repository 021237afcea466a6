"""Online 2D graph SLAM as a library (no ROS): scans and odometry in, the robot's pose in the map frame, the
map -> odom transform, an occupancy grid and a pose graph out.

The design is Cartographer's (Hess et al., ICRA 2016) with Karto's / slam_toolbox's graph:

- Nodes: a scan becomes a node when odometry has moved update_min_d (m) or turned update_min_a (rad) since the
  last node (slam_toolbox's minimum_travel_distance / minimum_travel_heading); between nodes the pose is the last
  node's composed with the odometry since.
- Front end: the node's scan (its points in the robot's frame: the LiDAR mount lidar_x/y/yaw) is matched
  (amr_maps.scan_matcher.CorrelativeMatcher, branch and bound then a sub-cell refinement) against the local submap,
  the likelihood field of the last local_window nodes' scan points (ScoreMap.from_points, to_points; the nodes added on
  odometry alone left out: their poses are unverified, unless the others saw fewer than MIN_BEAMS of the scan's
  points: then every recent node, and a match begins a new run of nodes, _segment_start; only the surfaces facing
  the odometry prior's sensor: _facing), with only the scan's points the window saw (_seen: within its scans'
  fields of view and the clear range of their beams without a return, judged at the odometry prior; where the
  window did not look, no wall is no evidence), within
  WINDOW_SIGMAS standard deviations of the odometry model (_odometry_model: ODOMETRY_SIGMA, the position's error
  growing with the distance and the turns, the heading's error half made before the step's translation) since the
  last node (since the newest matched node, when nodes were added on odometry alone since), at most
  +-match_linear_window / +-match_angular_window; the match is the posterior's mode over that window, the score's
  likelihood times the odometry prior (_posterior_mode), not the best score alone. It and its point-to-line refinement
  (_align) are weighed by their own informations (_refined: the score's curvature, the refinement's normal equations);
  the result is fused with the odometry prior as two Gaussians (along a corridor the odometry decides). The edges to
  the previous nodes (the newest matched one and the one before, at LINK_SHARES: _matched_sources) carry that
  estimate's covariance (_fused_covariance): the deciding scan estimate's own (the refinement's from its normal
  equations over its residuals' variance, of which the weights take a share, or the match's) and the odometry
  model's, by the gains the fusion gave them.
  A score below min_match_score (some overlap), or fewer than MIN_BEAMS usable beams,
  is not fatal: the node is added on odometry alone and the update's events say so. A weak match (below
  WEAK_MATCH_SCORE: a scan mostly of new ground, or a pose outside the window) is searched again over the whole
  angular window (match_angular_window: the odometry may be off by more than its model says), then tested: a rival
  mode in the window (_local_rival) widens its covariance to span both, and it is used only if it agrees with the
  odometry (MATCH_CHI2).
- Submaps for loop closure: every local_window consecutive nodes form a submap (scan points, as above), built
  in the frame of its middle node (the anchor) when first searched, from the poses then (rigid, as
  Cartographer's).
- Back end: after a node is added, the submaps whose anchor lies within loop_search_radius of the new pose and
  at least loop_min_travel of path behind it are searched, nearest first, at most loop_max_candidates per update
  and none started once the update's work (_Work: lookups counted, builds at their measured equivalent) reaches
  loop_work_budget (the next updates take the rest; deterministic: a run is repeatable), each by a windowed
  match (WindowMatch) within +-loop_angular_window of its node's estimate and, in x and y, over the region the gate
  would accept it in (_closure_window: the graph's own uncertainty of the node relative to the anchor, at least
  +-loop_linear_window). A candidate is
  taken a step at a time (_step_candidate: the submap's build and clear space, search slices, rival search slices,
  the gate): one that runs past CANDIDATE_WORK_CAP in its update goes on in the next ones (its searches resumed,
  none repeated), so no update carries a whole long search. A match
  scoring loop_min_score or more adds a loop-closure edge (anchor, node) unless it lies on the window's edge
  (_on_edge), puts scan points in the submap's seen-through space, a rival pose in the window scores nearly as
  well (ambiguous), or it disagrees with the poses beyond LOOP_CHI2 against its covariance (_closure_covariance: the
  refinement's and the submap's layout's) plus the graph's own uncertainty of the anchor -> node pose
  (PoseGraph.marginals of the graph's edges, earlier closures included);
  the graph is optimized (amr_mapping.pose_graph: sparse Levenberg-Marquardt, graduated Cauchy kernel on
  closures, so a false closure bends the map little), and a closure the optimized graph still disagrees with
  (LOOP_RESIDUAL_CHI2) is removed. The optimization's iterations are counted work too (OPTIMIZE_BUDGET an
  update, one iteration at least), the rest carried over to the next updates (each iteration lowers the cost of
  the graph as it is then: the poses, the map and the front end's submap are consistent meanwhile).
  An optimization that fails (MappingError) is reported in the events and the poses kept.
- The occupancy grid (amr_maps.scan_mapping.LogOddsGrid) follows the poses on request: a new node's scan inserted,
  a moved node's taken out and inserted again, all rebuilt when most nodes moved (KeptMap). KeptMap works on a
  snapshot of the graph (GraphSlam.snapshot: the poses copied, the nodes, immutable once added), so a caller may
  build the map on a thread of its own while the graph goes on (the slam node does, as slam_toolbox does).

Bad input: an odometry or stamp that is not finite, or a scan whose ranges do not match its angles, raises
MappingError and changes nothing. NaN and out-of-range readings are dropped beams. An odometry step longer than
max_odometry_jump (m) since the last call is taken as unknown motion: MappingError is raised, the pose is held
where it was and odometry is re-anchored at the new reading (map -> odom changes), so the next call goes on
from there.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree
from scipy.special import expit

from amr_mapping.errors import MappingError
from amr_mapping.point_field import neighbourhood_lines
from amr_mapping.pose_graph import Optimization, PoseGraph
from amr_maps.map_io import save_map
from amr_maps.occupancy_grid import FREE, MapError, OccupancyGrid
from amr_maps.scan_mapping import LogOddsGrid
from amr_maps.scan_matcher import CorrelativeMatcher, GlobalSearch, Match, ScoreMap, WindowMatch, default_angular_step
from amr_maps.window_search import window_modes
from amr_util.geometry import (
    compose,
    inverse,
    is_finite_number,
    odometry_covariance,
    odometry_turns,
    off_line,
    relative_pose,
    transform_points,
    wrap_angle,
)
from amr_util.robot_description import default_robot
from amr_util.scan import ScanData

MIN_BEAMS = 20
"""Fewer usable beams than this: the scan is not matched (the node is added on odometry alone)."""
ODOMETRY_SIGMA = (0.02, 0.07, 0.07, 0.02, 0.07)
"""The odometry model's standard deviations: (m, m per m travelled, m per rad turned along the line of travel, rad,
rad per rad turned + per m travelled), the terms of the motion model (Probabilistic Robotics, table 5.6: the
translation's error grows with the distance and with the turns, the heading's with both; AMCL's alpha1-alpha4), each
1.4 times the synthesized odometry's 5 % (amr_datasets.odometry), a margin for other robots: the front end's prior
and search window (WINDOW_SIGMAS) and its weight against the match; a link's covariance carries the robot's own
odometry error (SlamConfig.odometry_error_xy / odometry_error_theta: a share of these). Without the translation's
error per turn a turn in place (its reference slid 4 cm: a quarter turn each way, and 13 cm of the odometry's
translation error at 1 sigma) was searched within 7 cm: fhw played backwards took matches 20-47 deg off the truth
there, whose scans scored 0.08 better than the truth 17 cm off the prior, and ended 6-9 m off at seeds 1, 7 and 9.
At twice the synthesized odometry's terms (0.1) the logs played backwards met the ATE goal at 22 of 40 seeds, at 1.4
times 38 (the decision record's translation per turn round)."""
LINK_SHARES = (0.8, 0.2)
"""A matched scan's node is linked to its window's newest matched members (newest first), the link's information
shared among them at these shares: its pose is measured against the window's points, most against the newest scan's,
so its error is partly the newest node's own, taken back by the next match (consecutive links' heading errors
correlated -0.19 to -0.23 in the recorded maze runs; a link's error regressed on the links before it: -0.20 to -0.23
on the one before, -0.04 to -0.08 on the one before that: the reference 0.8 the newest node, 0.2 the one before).
Linked to the newest alone, a chain of links claimed a drift 1.5 times its own, and the graph spread a closure's
correction as if every link had erred alike (the decision record's window-link round). Shared evenly over 3 or 10
members the chain claimed a tenth of its drift and the logs' gate refused right closures (session 16)."""
LIKELIHOOD_SIGMA_CELLS = 1.5
"""The submaps' likelihood field: exp(-d^2 / (2 sigma^2)), sigma this many cells."""
OPTIMIZE_CHI = 3.0
"""A new closure this many standard deviations off the current poses starts an optimization of the graph ..."""
OPTIMIZE_EVERY = 10
"""... else one starts once this many closures that agree with the poses have been added."""
ONLINE_ITERATIONS = 10
"""Levenberg-Marquardt iterations of an optimization a closure starts (carried over several updates: see
OPTIMIZE_WORK_PER_EDGE)."""
OPTIMIZE_WORK_PER_EDGE = 1_700.0
"""Work units (see loop_work_budget) that one linear solve of the graph's normal equations costs per edge (an
iteration: about 8 us an edge on intel's 1,200-edge graph, against about 5 ns a lookup) ..."""
OPTIMIZE_BUDGET = 5e6
"""... and that an update spends at most on the optimization in progress, one iteration at least (about 3 iterations
of a 900-node graph, 25 ms): the rest is carried over to the next updates. The closures' search has its own budget
(loop_work_budget), spent before: an update's time is bounded whatever the closures (a 900-node graph's
optimization took up to 10 iterations, 60 ms, in one update; 150-230 ms with edges weighed by their own
covariances)."""
LIKELIHOOD_PAD = 1.0
"""m of field around a submap's points beyond the search windows (points off the table score 0)."""
SEEN_MARGIN_CELLS = 4.0
"""Cells beyond a window scan's clear range (a beam without a return) that still count as seen by it (_seen), on top
of the search window's reach: the scan's noise, the field's width."""
WINDOW_SIGMAS = 3.0
"""The front end searches this many standard deviations of the odometry model since the last node (at most
match_linear_window / match_angular_window)."""
MATCH_INFORMATION_SCALE = 200.0
"""A match's information per unit of negative curvature of the mean score (the points' effective count over
the score's noise variance: neighbouring beams are not independent)."""
MIN_MATCH_INFORMATION = 0.01
"""A match's information is at least this in every direction (a flat score: a standard deviation of 10 m, or
10 rad: little enough that the odometry decides, not so little that a direction mixing x, y and theta leaks
kilometres into the others)."""
MATCH_CHI2 = 11.34
"""A weak scan match (below WEAK_MATCH_SCORE) is used only when its offset from the odometry prior, against both
covariances, is within this chi-square (3 dof, 99 %); min_match_score only asks for some overlap."""
WEAK_MATCH_SCORE = 0.5
"""A scan match scoring below this (a scan mostly of new ground: orebro's 2-3 m keyframes turning a corner) ..."""
LOCAL_RIVAL_RATIO = 0.75
"""... with a rival pose in the search window at least AMBIGUITY_DISTANCE off scoring this share of it or more
has its covariance widened towards the rival by the rival's posterior share (_rival_share: the second moment of the
two-mode mixture about the match). On orebro two such matches, a parallel wall 0.4-0.75 m off, were taken at 3 cm
and threw the map 5 m."""
RIVAL_DIP = 0.8
"""... and a rival is a mode of its own when the pose halfway to it scores below this share of both."""
POSTERIOR_MIN_MARGIN = 0.002
"""A match whose odometry penalty is worth less than this much mean score is the posterior's mode as it is
(_posterior_mode: no search) ..."""
POSTERIOR_MODES = 8
POSTERIOR_SEPARATION_CELLS = 2.0
"""... else up to this many modes of the window, this many cells apart, are weighed."""
LOCAL_RIVAL_MAX_NODES = 100_000
"""The local rival search's budget (branch and bound nodes): it bounds a weak match's time."""
LOOP_CHI2 = 16.27
"""A loop-closure match is accepted when its offset from the poses now, against its covariance plus the
chain's since the anchor, is within this chi-square (3 dof, 99.9 %)."""
GATE_DRIFT_SCALE = 4.0
"""The gate takes the graph's own uncertainty of the anchor -> node relative pose (its marginals) this many times
over: the scan-match links claim less than they err on real logs (their chi-square at the corrected poses, median a
link: aces 5.7, fhw 16, intel 122, orebro 31), and the drift they add up to between closures is what the gate
weighs a closure against (intel played backwards, seed 0: 271 closures within 15 cm and 1.5 deg of the reference
refused, against 17 forwards)."""
CLOSURE_INFORMATION_SHARE = 0.1
"""A loop closure's point-to-line refinement counts this share of its normal equations' information: they measure the
scan's noise against the submap's lines, not the submap's own faults (a thin wall's far face: a closure submap keeps
every viewpoint's surfaces; its corners; its members bent beyond the layout), which a closure against a maze's submap
carries (its chi-square at the true poses: 8-250 mean at the whole information on the three runs that missed, 0.6-8
at this share on eight maze runs; a clean room's 2-5: the decision record's closures' covariance round)."""
LOOP_RESIDUAL_CHI2 = 16.27
"""After an optimization, a loop closure whose residual's chi-square is above this (3 dof, 99.9 %) is removed,
the worst first, one at a time: the others and the scan matches agree on a graph it does not fit."""
AMBIGUITY_DISTANCE = 0.2
"""m: a loop-closure match with a rival this far or further (anywhere in its search window, any heading) ..."""
AMBIGUITY_RATIO = 0.9
"""... scoring this share of its score or more is ambiguous and not used."""
SAVED_FREE_PROBABILITY = 0.5
"""A cell seen and more likely free than occupied is free in the saved map (_saved), as the published map is read
(the explorer's free_threshold 50 %, the planner's obstacles from 65 %). Saved as it is, map_server's trinary format
(free below 0.196, its unknown pixel's own value) kept the cells seen free once or twice (0.31-0.40) as never seen:
the explorer had judged them explored, and navigation on the saved map refused a goal among them as unknown (maze
rotated, seed 0)."""
CLEAR_PROBABILITY = 0.3
"""A loop-closure submap's cell is clear when its occupancy probability is at most this (two rays or more
crossed it, none ended there: one free observation makes 0.4) ..."""
CLEAR_MARGIN_CELLS = 2
"""... and no cell within this many cells is a wall (probability 0.5 or more: noise, a slightly bent submap)."""
LOOP_MAX_CLEAR_SHARE = 0.01
"""A loop-closure match puts at most this share of the scan's points in the submap's clear space: a wall seen
where the submap saw through (free-space consistency). A maze's cells one pitch apart match a scan nearly as
well by score, the mean likelihood counting a point in unseen space and one in seen-through space alike; but a
scan put a pitch off puts its walls across corridors the submap saw clear."""
EDGE_CELLS = 2.0
EDGE_ANGLE = 0.02
"""rad, cells: a loop-closure match this close to its search window's edge is no peak (_on_edge)."""
RIVAL_CHI2 = 13.82
"""... and lies where the graph's uncertainty would take the closure too: its position's chi-square (2 dof, 99.9 %)
against the gate's spread, the closure's covariance and the graph's of the anchor -> node pose (a look-alike place
the poses rule out is no ambiguity)."""
AMBIGUITY_MAX_NODES = 200_000
"""The rival search's budget (branch and bound nodes, each one lookup per point): it bounds a closure's work."""
CANDIDATE_WORK_CAP = 70.0
"""Millions of work units (see loop_work_budget) of an update's own after which a loop-closure candidate waits for the
next update (_step_candidate's steps): candidates are started as the search always was (within loop_work_budget, one
at least every other update) and each is decided in its update unless its searches run long (a rival search over a 6 m
window at any heading took up to 100 ms, a submap's build and clear space up to 60); what is left is taken on in the
next updates after their own starts, at most loop_max_candidates in progress. Lower caps spread more candidates and
moved the logs' closures (cap 40: orebro ATE 0.114 -> 0.272 m; 50: fhw 0.080 -> 0.104 m, 1.16 deg)."""
MIN_SEARCH_SLICE = 10_000
"""Branch and bound nodes a closure candidate's search step scores at least (GraphSlam._slice): a search spread over
the updates moves on however busy they are."""
ALIGN_VOXEL_CELLS = 0.5
"""The reference's points are averaged over squares this many cells wide (10 scans' noisy points on a wall) ..."""
ALIGN_NEIGHBOURS = 64
"""... and each average's line is the centroid and principal axes of the points (at most this many, at least
ALIGN_MIN_NEIGHBOURS) within ALIGN_NEIGHBOURHOOD_CELLS of it ..."""
ALIGN_MIN_NEIGHBOURS = 8
ALIGN_NEIGHBOURHOOD_CELLS = 4.0
ALIGN_FLATNESS = 0.5
"""... a line only where they lie along one (the small axis' spread below this share of the long one's)."""
ALIGN_DISTANCE_CELLS = 2.0
"""Point-to-line refinement: a scan point is paired with the nearest reference point this many cells away at
most; the refinement stays within this far of the correlative match too."""
ALIGN_ITERATIONS = 10
ALIGN_MIN_SIGMA = 0.005
"""m: the refinement's residuals are taken to scatter at least this much (its information's scale) ..."""
ALIGN_WEIGHT_SHARE = 0.05
"""... and the refinement weighs this share of its information against the correlative match's when the two are fused
(_refined: the estimator as measured best, the two being estimates from one scan); its covariance is its own, the
normal equations' (chi-square 3-6 at the true poses of recorded maze runs, 0.2 at this share)."""
ALIGN_MIN_PAIRS = 20
CONSTRAINT_REACH_CELLS = 4.5
"""Cells (3 sigma of the likelihood field) within which a scan point is taken to lie on a reference point's line
when the directions a match constrains are judged (_constrained)."""
ALIGN_EIGEN_RATIO = 1e-3
"""The refinement moves only along the directions the lines constrain: eigenvalues of its normal matrix below
this share of the largest are left out (along a corridor the correlative match and the odometry decide)."""
REFERENCE_WORK_PER_POINT = 3_400.0
"""Work units (a scan point looked up by a branch and bound) that building a reference costs per averaged point
(likelihood field, lines, tree: about 16 us each against 4.7 ns a lookup, measured once on aces; about a third of
that since the field is stamped around the points, kept so that the closures' schedule, and so a run, stays as it
was) ..."""
CLOSURE_OUTCOMES_KEPT = 10_000
"""closure candidates whose outcome GraphSlam keeps for diagnosis (the latest; a long run's memory stays bounded)."""
CLEAR_WORK_PER_RAY = 1_100.0
"""... that a loop-closure submap's clear space costs per ray (about 5 us) ..."""
CANDIDATE_WORK = 500_000.0
"""... and that a match's refinement and information cost besides its branch and bound (about 3 ms)."""
MIN_EDGE_SIGMA = (0.0005, math.radians(0.01))
"""m, rad: an edge's standard deviations are at least these (added in quadrature; a numerical floor, a tenth of
the smallest measured: a maze's links at LiDAR noise 0.01 m, 1 mm and 0.1 deg)."""


@dataclass(frozen=True)
class SlamConfig:
    """Parameters of GraphSlam, each with the range it is meant for."""

    resolution: float = 0.05
    """m per cell of the submaps and the map (0.02-0.1)."""
    update_min_d: float = 0.2
    """m of odometry travel since the last node that makes a scan a node (0-2; 0: every scan)."""
    update_min_a: float = 0.2
    """rad of odometry turn since the last node that makes a scan a node (0-pi)."""
    max_range_used: float = 20.0
    """m: readings beyond it are not mapped (free space is cleared up to it) nor matched (3-80)."""
    local_window: int = 10
    """nodes in the local submap (the front end's reference) and in each loop-closure submap (3-50)."""
    match_linear_window: float = 1.5
    """m, +- in x and y around the odometry prior that scan-to-submap matching searches at most: it searches 3
    standard deviations of the odometry model since the last node (0.05-2)."""
    match_angular_window: float = 1.0
    """rad, +- around the odometry prior's heading at most, as match_linear_window (0.05-1)."""
    min_match_score: float = 0.2
    """a scan match below this mean likelihood (0-1) is not used: the node is added on odometry alone (a weak
    match, below WEAK_MATCH_SCORE, must also agree with the odometry, a rival mode widening it by its posterior
    share)."""
    loop_search_radius: float = 5.0
    """m: submaps whose anchor lies this close to the new node's pose are loop-closure candidates (0.5-20)."""
    loop_linear_window: float = 3.0
    """m, +- in x and y around the current estimate that a loop-closure match searches at least; wider where the
    graph's own uncertainty of the node relative to the submap says the gate would accept it further (0.2-10)."""
    loop_angular_window: float = 0.6
    """rad, +- around the current heading that a loop-closure match searches (0.1-pi)."""
    loop_min_score: float = 0.3
    """a loop-closure match must score this mean likelihood (0-1) to be tested (free space, rivals, the graph's
    uncertainty) as a closure."""
    loop_min_travel: float = 8.0
    """m of path between a candidate submap's last node and the new node (the local submap is no loop) (1-100)."""
    loop_max_candidates: int = 2
    """submaps matched for loop closure per update at most: bounds an update's time (1-10)."""
    loop_work_budget: float = 10.0
    """millions of work units (one: a scan point looked up by a branch and bound, 1-5 ns here; a submap's
    build counted at its measured equivalent) of the update's own (front end included) after which no further
    loop-closure candidate is started (the rest wait for the next updates; a step at least every other update;
    a candidate started goes on to CANDIDATE_WORK_CAP, then on the next updates): bounds an update's time, and
    unlike a clock the same on every run (0-1000)."""
    odometry_error_xy: float = 1.0
    """the robot's odometry error in position as a share of the odometry model's standard deviations (ODOMETRY_SIGMA,
    the front end's prior and window, with a margin over a log's synthesized odometry for other robots): a link's
    covariance carries its odometry's share at this, so a chain of links claims the drift it makes (0.01-1; the
    simulator's odometry: 0.15, the maze_mapping stack's)."""
    odometry_error_theta: float = 1.0
    """... and in heading (0.01-1; the simulator's: 0.3)."""
    max_odometry_jump: float = 5.0
    """m: an odometry step longer than this between two calls is unknown motion (MappingError) (0.5-100)."""
    lidar_x: float = default_robot().lidar_x
    """m, the scan's origin ahead of the robot's (base_scan in base_footprint); the robot description's by
    default."""
    lidar_y: float = default_robot().lidar_y
    """m, the scan's origin left of the robot's; the robot description's by default."""
    lidar_yaw: float = 0.0
    """rad, the scan's angle 0 from the robot's heading."""

    def __post_init__(self) -> None:
        positive = (
            "resolution",
            "max_range_used",
            "match_linear_window",
            "match_angular_window",
            "loop_search_radius",
            "loop_linear_window",
            "loop_angular_window",
            "max_odometry_jump",
            "odometry_error_xy",
            "odometry_error_theta",
        )
        signed = ("lidar_x", "lidar_y", "lidar_yaw")
        for item in fields(self):
            value = getattr(self, item.name)
            if item.name in signed:
                if not is_finite_number(value) or abs(value) > 10.0:
                    raise MappingError(f"slam config: {item.name}: must be a finite number within 10, got {value!r}")
                continue
            if item.name in ("local_window", "loop_max_candidates"):
                if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                    raise MappingError(f"slam config: {item.name}: must be an integer >= 1, got {value!r}")
                continue
            if not is_finite_number(value) or value < 0.0 or (item.name in positive and value == 0.0):
                raise MappingError(
                    f"slam config: {item.name}: must be a finite number "
                    f"{'> 0' if item.name in positive else '>= 0'}, got {value!r}"
                )
        for name in ("min_match_score", "loop_min_score"):
            if getattr(self, name) > 1.0:
                raise MappingError(f"slam config: {name}: must be a score in 0..1, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class LoopClosure:
    """A loop-closure edge added: from the submap anchor node to the new node, with the match's score."""

    anchor: int
    node: int
    score: float


@dataclass(frozen=True)
class SlamUpdate:
    """What one GraphSlam.add did: the pose in the map frame now, whether the scan became a node (its index),
    the scan match's score (None: not matched), the loop closures added, whether the map changed (a node added
    or the poses optimized), the wall time (s) and events worth a log line."""

    pose: tuple[float, float, float]
    node_added: bool
    node: int | None
    match_score: float | None
    loop_closures: tuple[LoopClosure, ...]
    map_changed: bool
    seconds: float
    events: tuple[str, ...] = ()


class _Work:
    """An update's work so far, in units of one scan point looked up by a branch and bound (the builds and the
    refinement counted at their measured equivalents): what loop_work_budget bounds; a count, not a clock, so a
    run does the same whatever the machine's load."""

    def __init__(self) -> None:
        self.units = 0.0

    def add(self, units: float) -> None:
        self.units += float(units)


@dataclass
class _Reference:
    """What a scan is matched against: the correlative matcher on the likelihood field of the scan points, and
    the points themselves with their normals for the point-to-line refinement (_align)."""

    matcher: CorrelativeMatcher
    points: np.ndarray
    """(K, 2) the scan points averaged per ALIGN_VOXEL_CELLS square (the anchor's frame); the tree finds the
    nearest to a point of the scan matched."""
    centres: np.ndarray
    """(K, 2) the centroid of each point's neighbourhood: a point on its line (the noise averaged)."""
    normals: np.ndarray
    """(K, 2) unit normals; NaN where the neighbourhood is not a line (a corner, a lone point)."""
    tree: cKDTree
    clear: OccupancyGrid | None = None
    """A loop-closure submap's clear space (100 where its rays crossed a cell repeatedly, CLEAR_PROBABILITY, and
    no wall lies within CLEAR_MARGIN_CELLS; else 0), the anchor's frame: where no scan point may land."""


@dataclass
class _Submap:
    """Nodes last - local_window + 1 .. last in the frame of the anchor node; the reference is built when the
    submap is first searched for a closure (GraphSlam._reference_of), within that update's budget, from the poses
    then (not on the completing node's update: an update's time)."""

    anchor: int
    last: int
    reference: _Reference | None = None
    layout: np.ndarray | None = None
    placed: np.ndarray | None = None
    """(local_window, 3) its members' poses in the anchor's frame when its reference was built: its clear space,
    built later (GraphSlam._clear_of), puts their scans where the matcher has their points."""
    """(3, 3) how far its members' layout may be off, as one rigid motion at the anchor (_layout_covariance)."""

    @property
    def matcher(self) -> CorrelativeMatcher:
        return self.reference.matcher


@dataclass(frozen=True)
class _LocalWindow:
    """The local window a scan is matched against (GraphSlam._local_window): the nodes it is built of and what the match
    needs of it."""

    members: list[int]
    odometry_information: np.ndarray
    """The odometry model since the newest member, in the anchor's frame (the prior's information)."""
    motion: np.ndarray
    path: float
    turn: float
    turned: float
    """The turn between the newest member and the anchor (the model's frame carried to the anchor's)."""
    reference: _Reference
    linear: float
    angular: float
    seen: np.ndarray
    """Which of the scan's points the members saw (_seen, at the prior)."""
    restarts: bool = False
    """Every recent node, unverified ones too: a match against it begins a new run of nodes (_segment_start)."""


@dataclass
class _Candidate:
    """A loop-closure candidate in progress: submap `submap` (an index of GraphSlam._submaps) searched for node
    `node`, a step at a time (GraphSlam._step_candidate), the steps spread over the updates by CANDIDATE_WORK_CAP."""

    submap: int
    node: int
    points: np.ndarray
    prior: np.ndarray
    """The node's pose in the anchor's frame when the candidate was started: the centre of the search window."""
    search: WindowMatch | None = None
    match: Match | None = None
    matched: np.ndarray | None = None
    aligned_information: np.ndarray | None = None
    rival: GlobalSearch | None = None
    """The search for a rival of the match (_rival_search), in progress."""
    unambiguous: bool = False
    """The rival search is over and found none: the gate is next."""
    linear: float = 0.0
    """m, +- the search window in x and y around the prior (_closure_window), set when the search starts."""


@dataclass
class _Node:
    stamp_ns: int
    odometry: np.ndarray
    ranges: np.ndarray
    angles: np.ndarray
    points: np.ndarray
    travelled: float
    """m of odometry path from the first node."""
    clear_range: float
    """m a beam without a return clears: the sensor's range_max, at most max_range_used."""


@dataclass(frozen=True)
class SlamSnapshot:
    """The graph at one moment (GraphSlam.snapshot): the arrays copied and the nodes themselves (immutable once
    added; the list of them only grows), so another thread may read it while the graph goes on."""

    poses: np.ndarray
    """(N, 3) the nodes' poses, map frame."""
    edges: np.ndarray
    """(M, 2) int node pairs."""
    loop: np.ndarray
    """(M,) bool: which edges are loop closures."""
    node_stamps: tuple[int, ...]
    """Each node's stamp (ns)."""
    nodes: tuple[_Node, ...]
    mount: np.ndarray
    """The LiDAR on the robot (lidar_x, lidar_y, lidar_yaw)."""


class KeptMap:
    """The log-odds map of every node's scan at its pose, kept up to date from snapshot to snapshot (build): a new
    node's scan inserted, a node's scan that moved since it was inserted taken out (LogOddsGrid.insert, sign -1: the
    same cells exactly) and inserted again; all of it rebuilt when more than half the nodes moved (an optimization
    moves the whole graph). Between optimizations a build is one scan's work, not every node's (intel: 63 % of the
    updates, aces 96 %; a rebuild at 900 nodes 120 ms). The kept map never shrinks (cells only the old poses covered
    stay, unknown); GraphSlam.save rebuilds it. It touches nothing but the snapshot it is given and its own grid:
    one build at a time, on any thread."""

    CHUNK = 16
    """Scans inserted between two calls of a build's pause (a few ms)."""

    def __init__(self, resolution: float) -> None:
        self.resolution = float(resolution)
        self._log_odds: LogOddsGrid | None = None
        self._inserted = np.zeros((0, 3))  # the pose each node's scan was inserted into the log odds at
        self._grid: OccupancyGrid | None = None  # the last build's, while no node moved or was added

    def build(self, snapshot: SlamSnapshot, pause: Callable[[], object] | None = None) -> OccupancyGrid:
        """The occupancy grid of the snapshot's nodes at its poses (the last build's grid itself when nothing
        changed since). `pause`, when given, is called between chunks of CHUNK scans and before the grid's
        conversion: a caller building on a thread of its own waits there while its other thread has something more
        urgent (the slam node: a pair to answer); the grid is the same. No node: MappingError."""
        poses, nodes = np.asarray(snapshot.poses, dtype=float).reshape(-1, 3), snapshot.nodes
        if not len(nodes):
            raise MappingError("slam: no map yet (no scan has been added)")
        if len(poses) != len(nodes):
            raise MappingError(f"slam: a snapshot of {len(poses)} poses and {len(nodes)} nodes")
        if self._grid is None or not np.array_equal(poses, self._inserted):
            log_odds = self._updated(poses, nodes, snapshot.mount, pause)
            if pause is not None:
                pause()
            self._grid = log_odds.to_occupancy_grid()
        return self._grid

    def _updated(self, poses: np.ndarray, nodes, mount, pause) -> LogOddsGrid:
        """The log-odds map brought to the poses (see the class)."""
        inserted = self._inserted
        if self._log_odds is not None and len(inserted) <= len(poses):
            moved = np.flatnonzero(np.any(poses[: len(inserted)] != inserted, axis=1))
            if len(moved) <= 0.5 * len(inserted):
                grid = self._log_odds
                for count, k in enumerate(moved):
                    if pause is not None and count and count % self.CHUNK == 0:
                        pause()
                    node = nodes[k]
                    args = (node.ranges, node.angles, node.clear_range)
                    grid.insert(compose(inserted[k], mount), *args, sign=-1)
                    grid.insert(compose(poses[k], mount), *args)
                    inserted[k] = poses[k]
                self._insert(poses, nodes, mount, range(len(inserted), len(poses)), pause)
                return grid
        self._log_odds, self._inserted = LogOddsGrid(self.resolution), np.zeros((0, 3))
        self._insert(poses, nodes, mount, range(len(poses)), pause)
        return self._log_odds

    def _insert(self, poses: np.ndarray, nodes, mount, indices, pause=None) -> None:
        """The scans of nodes `indices` inserted into the log-odds map at their poses (noted in _inserted): at once,
        or CHUNK at a time with a pause between (LogOddsGrid.insert_many: the same cells, values and origin)."""
        indices = list(indices)
        step = len(indices) if pause is None else self.CHUNK
        for start in range(0, len(indices), max(step, 1)):
            if start:
                pause()
            chunk = indices[start : start + step]
            _insert(self._log_odds, poses[chunk], [nodes[k] for k in chunk], mount)
            self._inserted = np.vstack([self._inserted, poses[chunk]])


class GraphSlam:
    """Online graph SLAM; see the module docstring."""

    def __init__(self, config: SlamConfig | None = None) -> None:
        self.config = SlamConfig() if config is None else config
        self._graph = PoseGraph()
        self._nodes: list[_Node] = []
        self._submaps: list[_Submap] = []
        self._odometry: np.ndarray | None = None  # the last odometry reading
        self._anchor_odometry: np.ndarray | None = None  # the odometry that the last node's pose stands for
        self._pose = np.zeros(3)
        self._travelled = 0.0
        self._map = KeptMap(self.config.resolution)  # occupancy_grid's
        self._unmatched: set[int] = set()  # nodes added on odometry alone (left out of the local submap)
        self._pending: list[int] = []  # candidate submaps not yet searched for the last node
        self._candidates: list[_Candidate] = []  # closure candidates in progress, oldest first (_step_candidate)
        self._local: tuple[tuple, _Reference, list] | None = None  # ((last, members), reference, views)
        self._window: _LocalWindow | None = None  # the last local window a scan was matched against
        self._segment_start = 0  # the first node of the newest match-linked run: older nodes leave the window
        self._unoptimized = 0  # closures added since the last optimization
        self._run: Optimization | None = None  # the optimization in progress (carried over the updates)
        self._drops = 0  # closures the run in progress may still remove (_advance_optimization)
        self._starved = False  # the last update searched no closure candidate (loop_work_budget)
        self._work = _Work()  # the update's work so far
        self._mount = np.array([self.config.lidar_x, self.config.lidar_y, self.config.lidar_yaw], dtype=float)
        self.searched_closures = 0  # closure candidates matched (a submap searched for the new node)
        self.closure_outcomes: deque[tuple[int, int, str, np.ndarray]] = deque(maxlen=CLOSURE_OUTCOMES_KEPT)
        """The last CLOSURE_OUTCOMES_KEPT closure candidates searched: (anchor, node, outcome, the match in the anchor's
        frame); outcome one of low score, edge, clear, ambiguous, gate, kept (a diagnostic:
        bench/bench_slam_replay.py)."""
        self.rejected_closures = 0  # closure matches that scored but disagreed with the poses (LOOP_CHI2)
        self.ambiguous_closures = 0  # closure matches with a rival in the window (AMBIGUITY_RATIO)
        self.inconsistent_closures = 0  # closure matches putting points in the submap's clear space
        self.dropped_closures = 0  # closures removed after an optimization (LOOP_RESIDUAL_CHI2)
        # covariance of node k's link (to k - 1, or to the newest matched nodes before it: _matched_sources), k's frame
        self._links: list[np.ndarray] = [np.zeros((3, 3))]

    # -- state -----------------------------------------------------------------------------------------

    @property
    def pose(self) -> tuple[float, float, float]:
        """The robot's pose in the map frame now (x, y, theta)."""
        return tuple(float(v) for v in self._pose)

    @property
    def map_to_odom(self) -> tuple[float, float, float]:
        """The odom frame in the map frame (x, y, theta): pose (+) inverse(odometry), identity before any scan."""
        if self._odometry is None:
            return 0.0, 0.0, 0.0
        return tuple(float(v) for v in compose(self._pose, inverse(self._odometry)))

    @property
    def node_stamps(self) -> list[int]:
        """Each node's stamp (ns)."""
        return [node.stamp_ns for node in self._nodes]

    def graph(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(poses (N, 3), edges (M, 2) int, loop (M,) bool)."""
        return self._graph.poses, self._graph.edges, self._graph.loop

    def occupancy_grid(self) -> OccupancyGrid:
        """The map from every node's scan at its optimized pose (brought to the poses when they changed: KeptMap).
        No node yet: MappingError."""
        if not self._nodes:
            raise MappingError("slam: no map yet (no scan has been added)")
        return self._map.build(self.snapshot())

    def snapshot(self) -> SlamSnapshot:
        """The graph now, for another thread (KeptMap.build, a pose graph message): the poses, edges, loop flags and
        stamps copied, the nodes themselves (immutable once added). O(nodes + edges) copies, no map work."""
        nodes = tuple(self._nodes)
        return SlamSnapshot(
            self._graph.poses,
            self._graph.edges,
            self._graph.loop,
            tuple(node.stamp_ns for node in nodes),
            nodes,
            self._mount.copy(),
        )

    def save(self, path: str | Path) -> list[Path]:
        """Writes <path>.yaml + <path>.pgm (map_server's format) and <path>.poses.csv (stamp_ns,x,y,theta per
        node, map frame); returns the paths. An optimization still running over the updates, or closures waiting
        for one, is finished first (settle: the map saved is the optimized graph's; if it fails, the poses as they
        are). A file that cannot be written: MappingError naming it (the map is kept). The same as settle, then
        save_snapshot of the snapshot (the node holds its lock for the first two only)."""
        self.settle()
        return save_snapshot(self.snapshot(), self.config, path)

    def settle(self) -> bool:
        """The optimization a save needs finished: one still running over the updates, or closures waiting for
        one (OPTIMIZE_EVERY); a failed one leaves the poses as they are. True when the poses moved."""
        if self._run is None and not self._unoptimized:
            return False
        try:
            return self.optimize()
        except MappingError:
            return False  # the poses kept: the map as it is

    def optimize(self) -> bool:
        """Optimizes the graph now (the closures whose optimization was deferred, see OPTIMIZE_EVERY): before a
        save, at the end of a run. True when the poses moved; a failed optimization raises MappingError (poses
        kept)."""
        self._unoptimized = 0
        self._run = None
        if not self._graph.loop.any():
            return False
        result = self._optimize(30, [])
        if result.max_change > 0.0:
            self._local = None
            last = len(self._nodes) - 1
            self._pose = np.array(compose(self._graph.pose(last), relative_pose(self._anchor_odometry, self._odometry)))
        return result.max_change > 0.0

    # -- the update --------------------------------------------------------------------------------------

    def add(self, stamp_ns: int, odometry, scan: ScanData) -> SlamUpdate:
        """One scan with the odometry pose (x, y, theta, odom frame) at its stamp; see the module docstring."""
        start = time.perf_counter()
        self._work = _Work()
        if not isinstance(stamp_ns, (int, np.integer)) or isinstance(stamp_ns, bool):
            raise MappingError(f"slam: stamp_ns must be an integer of nanoseconds, got {stamp_ns!r}")
        odometry = np.asarray(odometry, dtype=float).reshape(-1)
        if odometry.shape != (3,) or not np.all(np.isfinite(odometry)):
            raise MappingError(f"slam: odometry must be 3 finite numbers (x, y, theta), got {odometry!r}")
        ranges, angles, points = _beams(scan, self.config.max_range_used, self._mount)
        clear_range = min(self.config.max_range_used, float(scan.range_max))
        events: list[str] = []
        if self._odometry is not None:
            jump = math.hypot(*(odometry[:2] - self._odometry[:2]))
            if jump > self.config.max_odometry_jump:
                # unknown motion: hold the pose, re-anchor odometry at the new reading
                self._odometry = odometry.copy()
                self._anchor_odometry = compose(
                    odometry, relative_pose(self._pose, self._graph.pose(len(self._nodes) - 1))
                )
                raise MappingError(
                    f"slam: odometry jumped {jump:.2f} m in one step (max_odometry_jump "
                    f"{self.config.max_odometry_jump} m): taken as unknown motion, pose held at "
                    f"({self._pose[0]:.2f}, {self._pose[1]:.2f})"
                )
            self._travelled += math.hypot(*relative_pose(self._odometry, odometry)[:2])
        self._odometry = odometry.copy()

        if not self._nodes:
            node = self._add_node(stamp_ns, odometry, odometry, ranges, angles, points, clear_range)
            self._pose = odometry.copy()
            events.append("first node")
            return SlamUpdate(self.pose, True, node, None, (), True, time.perf_counter() - start, tuple(events))

        delta = np.array(relative_pose(self._anchor_odometry, odometry))
        last = len(self._nodes) - 1
        prior = np.array(compose(self._graph.pose(last), delta))
        if not makes_node(delta, self.config):
            self._pose = prior
            return SlamUpdate(self.pose, False, None, None, (), False, time.perf_counter() - start, ())

        pose, covariance, score = self._match_local(prior, points, delta, events)
        node = self._add_node(stamp_ns, pose, odometry, ranges, angles, points, clear_range)
        sources = [last]
        if pose is prior:  # matched nothing (_match_local hands back the prior itself): its odometry step alone
            self._unmatched.add(node)
        else:
            sources = self._matched_sources(last)
            if self._window.restarts:
                self._segment_start = node
        shares = np.array(LINK_SHARES[: len(sources)]) / sum(LINK_SHARES[: len(sources)])
        self._links.append(covariance)
        information = _information(covariance)  # in the node's own frame, whichever the source
        for source, share in zip(sources, shares, strict=True):
            self._graph.add_edge(source, node, relative_pose(self._graph.pose(source), pose), share * information)
        self._pose = pose.copy()
        closures = self._close_loops(node, events)
        self._advance_optimization(node, events)
        return SlamUpdate(
            self.pose, True, node, score, tuple(closures), True, time.perf_counter() - start, tuple(events)
        )

    # -- internals ---------------------------------------------------------------------------------------

    def _add_node(self, stamp_ns, pose, odometry, ranges, angles, points, clear_range) -> int:
        index = self._graph.add_node(pose)
        self._nodes.append(_Node(int(stamp_ns), odometry.copy(), ranges, angles, points, self._travelled, clear_range))
        self._anchor_odometry = odometry.copy()
        window = self.config.local_window
        if (index + 1) % window == 0:  # a submap is complete: nodes index - window + 1 .. index
            self._submaps.append(_Submap(index - window // 2, index))
        return index

    def _matched_sources(self, last: int) -> list[int]:
        """The nodes a scan matched against the local submap is linked to (LINK_SHARES, newest first): the newest
        nodes of that submap's window that were matched themselves, not a node left out of the window as added on
        odometry alone (the match places the scan against the window's points, not against that node's unverified
        pose: linked to it, the scan's pose relative to the nodes before would carry the odometry step's covariance
        until the next closure, and the closures' gate with it, wide enough for a look-alike place); the newest of
        every recent node when the window was made of them (_match_local: none verified, or the verified ones saw
        almost none of the scan)."""
        return self._window.members[::-1][: len(LINK_SHARES)]

    def _verified(self, members) -> list[int]:
        """The members whose poses a scan match placed (the nodes added on odometry alone left out: their poses are
        unverified), or all of them if none was: the nodes whose scans a submap, local or for a closure, is built of."""
        return [k for k in members if k not in self._unmatched] or list(members)

    def _hold_points(self, members) -> bool:
        """Whether the members' scans hold MIN_BEAMS points or more: a window or submap to match against."""
        return sum(len(self._nodes[k].points) for k in members) >= MIN_BEAMS

    def _submap_range(self, submap: _Submap) -> range:
        """The nodes a loop-closure submap spans (its members, verified or not)."""
        return range(submap.last - self.config.local_window + 1, submap.last + 1)

    def _reference_of(self, submap: _Submap) -> _Reference:
        """The loop-closure submap's matcher and layout, built on first use (see _Submap); its clear space in the next
        step (_clear_of)."""
        if submap.reference is None:
            members = self._submap_range(submap)
            verified = self._verified(members)
            reference = self._matcher(submap.anchor, verified, self.config.loop_linear_window)
            # a member left out is a leaf on its odometry link (_matched_sources): its link moves none of the points
            links = [self._links[k] if k in verified else np.zeros((3, 3)) for k in members[1:]]
            submap.layout = _layout_covariance(
                self._graph.poses[members.start : members.stop], np.asarray(links), submap.anchor - members.start
            )
            submap.placed = np.array(
                [relative_pose(self._graph.pose(submap.anchor), self._graph.pose(k)) for k in members]
            )
            submap.reference = reference
        return submap.reference

    def _clear_of(self, submap: _Submap) -> OccupancyGrid:
        """The loop-closure submap's clear space (_Reference.clear), built on first use (the step after its matcher,
        at the members' poses the matcher was built at)."""
        reference = self._reference_of(submap)
        if reference.clear is None:
            span = self._submap_range(submap)
            members = self._verified(span)
            reference.clear = self._clear_space(members, submap.placed[np.asarray(members) - span.start])
            self._work.add(CLEAR_WORK_PER_RAY * sum(len(self._nodes[k].ranges) for k in members))
        return reference.clear

    def _matcher(self, anchor: int, members, window: float, viewpoint=None) -> _Reference:
        """A matcher on the likelihood field of the members' scan points (their endpoints, Olson's rasterized
        scans), in the anchor node's frame, window + LIKELIHOOD_PAD m around them; with a viewpoint (x, y in that
        frame: where the scan to be matched is expected to be taken), only the points on surfaces facing it
        (_facing). Not the log-odds map's
        occupied cells: its rays, passing a wall at a grazing angle, clear the cells the wall's far end was
        seen in, so the field is thin far down a corridor and a new scan, seeing further ahead, matched 20-40 cm
        short per metre on aces."""
        anchor_pose = self._graph.pose(anchor)
        poses = np.array([relative_pose(anchor_pose, self._graph.pose(k)) for k in members])
        clouds, sensors = [], []
        for pose, k in zip(poses, members, strict=True):
            clouds.append(transform_points(pose, self._nodes[k].points))
            sensors.append(np.broadcast_to(np.array(compose(pose, self._mount)[:2]), clouds[-1].shape))
        reference = _window_reference(np.vstack(clouds), np.vstack(sensors), self.config.resolution, window, viewpoint)
        self._work.add(REFERENCE_WORK_PER_POINT * len(reference.points))
        return reference

    def _views(self, anchor: int, members) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """The members' scans as what they saw (_seen): each its sensor's pose in the anchor node's frame, its beams'
        angles (ascending) and reach (unbounded where the beam hit something, else its clear range)."""
        anchor_pose = self._graph.pose(anchor)
        views = []
        for k in members:
            node = self._nodes[k]
            sensor = np.array(compose(relative_pose(anchor_pose, self._graph.pose(k)), self._mount))
            # a beam that hit something saw along its whole line (what lies behind the surface scores by its distance
            # from it: judged at a prior off by more than its window, the points that contradict it would be the
            # ones dropped); one without a return saw to its clear range, beyond which the window has no points
            hit = np.isfinite(node.ranges) & (node.ranges <= node.clear_range)
            reach = np.where(hit, np.inf, node.clear_range)
            order = np.argsort(node.angles)
            views.append((sensor, node.angles[order].astype(float), reach[order].astype(float)))
        return views

    def _clear_space(self, members, placed: np.ndarray) -> OccupancyGrid:
        """The members' scans mapped (log odds) at their poses `placed` (the anchor node's frame): the cells seen
        clear (see _Reference.clear)."""
        grid = LogOddsGrid(self.config.resolution)
        _insert(grid, placed, [self._nodes[k] for k in members], self._mount)
        margin = int(CLEAR_MARGIN_CELLS)
        # the walls dilated by a square: a separable maximum, the same cells as binary_dilation's (twice as fast)
        walls = ndimage.maximum_filter(grid.probability_at_least(0.5), size=2 * margin + 1, mode="constant", cval=0)
        clear = grid.observed() & grid.probability_at_most(CLEAR_PROBABILITY) & ~walls
        return OccupancyGrid(np.where(clear, 100, 0).astype(np.int8), self.config.resolution, (*grid.origin, 0.0))

    def _match_local(
        self, prior: np.ndarray, points: np.ndarray, delta: np.ndarray, events: list[str]
    ) -> tuple[np.ndarray, np.ndarray, float | None]:
        """(pose, covariance, score): the scan matched against the local submap within 3 sigma of the odometry model
        since the last node (the newest matched one: the window's newest member), fused with the odometry prior, and
        that estimate's covariance (the new node's frame: _fused_covariance); or the prior alone (the same array) and
        the odometry model's covariance."""
        cfg = self.config
        # the odometry's own error (what the estimate carries of it), not the prior's width: a node added on it is
        # linked to the last node by this step alone (in the new node's frame, as a link's covariance is)
        odometry_covariance = _rotated(
            _odometry_model(delta, share_xy=cfg.odometry_error_xy, share_theta=cfg.odometry_error_theta), delta[2]
        )
        if len(points) < MIN_BEAMS:
            events.append(f"scan has {len(points)} usable beams (< {MIN_BEAMS}): node added on odometry alone")
            return prior, odometry_covariance, None
        last = len(self._nodes) - 1
        anchor = self._graph.pose(last)
        relative_prior = np.array(relative_pose(anchor, prior))
        recent = range(max(0, last - cfg.local_window + 1), last + 1)
        # a node added on odometry alone stands where the odometry put it, unverified: not a reference (fhw's
        # turn in place: two such nodes 4.5 and 6 deg off, and the next matches took their headings from them) ...
        verified = [k for k in recent if k >= self._segment_start and k not in self._unmatched]
        window = self._local_window(recent, verified, prior, relative_prior, points, delta) if verified else None
        if window is None or (window.seen.sum() < MIN_BEAMS and len(verified) < len(recent)):
            # ... unless none is, or the verified saw almost none of what the scan sees (a few unverified steps on,
            # the robot turned or went where they did not look: intel played backwards, scans 88-95 saw 15 to 0 of
            # 180 points, each added on odometry alone until the window held none verified): then the window is
            # every recent node at the graph's poses (the unverified at the odometry's), and a match against it
            # begins a new run of nodes (_segment_start): the windows after it leave the nodes before it out, whose
            # poses the new ones are consistent with only through that window (mixed, the ring's nodes after a
            # forced stretch walked 5 deg)
            window = self._local_window(recent, list(recent), prior, relative_prior, points, delta, restarts=True)
        if window is None:
            events.append("the local window's scans hold no points to match against: node added on odometry alone")
            return prior, odometry_covariance, None
        self._window = window
        reference, linear, angular = window.reference, window.linear, window.angular
        odometry_information = window.odometry_information
        matcher = reference.matcher
        if window.seen.sum() >= MIN_BEAMS:  # else a scan of new ground: all of it, the weak match's tests decide
            points = points[window.seen]
        match = matcher.match(points, relative_prior, linear, angular)
        self._work.add(CANDIDATE_WORK + match.nodes * len(points))
        if match.score < WEAK_MATCH_SCORE and angular < cfg.match_angular_window:
            # nothing in 3 sigma fits well: the odometry may be off by more than its model says (a turn on the
            # spot: intel's scan 629, 17.5 deg off against a 9 deg window, the true pose scoring 0.84 outside it)
            wide = matcher.match(points, relative_prior, linear, cfg.match_angular_window)
            self._work.add(wide.nodes * len(points))
            if wide.score > match.score:
                events.append(
                    f"scan match {match.score:.2f} within 3 sigma of the odometry; {wide.score:.2f} "
                    f"{math.degrees(abs(wrap_angle(wide.pose[2] - relative_prior[2]))):.0f} deg off it in the "
                    "whole angular window: the better one used"
                )
                match, angular = wide, cfg.match_angular_window
        match = _posterior_mode(
            matcher, points, match, relative_prior, odometry_information, (linear, angular), self._work
        )
        if match.score < cfg.min_match_score or not np.all(np.isfinite(match.pose)):
            events.append(
                f"scan match score {match.score:.2f} < min_match_score {cfg.min_match_score}: "
                "node added on odometry alone"
            )
            return prior, odometry_covariance, float(match.score)
        matched, match_information, match_covariance = _refined(reference, points, match.pose, cfg.resolution)
        if match.score < WEAK_MATCH_SCORE:
            weak = _weak_match(
                matcher,
                points,
                match,
                matched,
                match_information,
                relative_prior,
                odometry_information,
                events,
                (linear, angular),
                self._work,
            )
            if weak is None:
                return prior, odometry_covariance, float(match.score)
            # widened over a rival mode: the covariance by as much as the weights
            match_covariance = match_covariance + np.linalg.inv(weak) - np.linalg.inv(match_information)
            match_information = weak
        fused = _fused(matched, match_information, relative_prior, odometry_information)
        pose = np.array(compose(anchor, fused))
        covariance = _fused_covariance(
            (match_information, match_covariance),
            (
                odometry_information,
                _rotated(
                    _odometry_model(
                        window.motion, window.path, window.turn, cfg.odometry_error_xy, cfg.odometry_error_theta
                    ),
                    window.turned,
                ),
            ),
        )
        return pose, _rotated(covariance, fused[2]), float(match.score)

    def _local_window(
        self, recent, members: list[int], prior, relative_prior, points, delta, restarts: bool = False
    ) -> _LocalWindow | None:
        """The local window of `members` (of the `recent` nodes) for a scan at `prior` (relative_prior: in the frame of
        the newest node, the anchor); None when their scans hold no points."""
        cfg = self.config
        last = recent[-1]
        if not self._hold_points(members):
            return None
        # the prior is as uncertain against the reference as the odometry since the newest node the reference is
        # built of: past nodes added on odometry alone widen its window and weaken its weight (orebro, odometry seed
        # 2: a 3 m step 1.3 m and 20 deg off went on odometry alone, and the next eight scans, each searched within
        # its own step's 3 sigma, missed their true poses, 0.5-1.3 m away)
        newest = members[-1]
        steps = [relative_pose(self._graph.pose(k), self._graph.pose(k + 1)) for k in range(newest, last)]
        steps.append(delta)
        # the model on the path and the turns since (their sum: a turn in place back and forth is no net motion)
        path = sum(math.hypot(step[0], step[1]) for step in steps)
        turn = sum(_turned(step) for step in steps)
        motion = np.array(relative_pose(self._graph.pose(newest), prior))
        # the model in the frame the motion began in (the newest member's), carried to the anchor's
        turned = wrap_angle(self._graph.pose(last)[2] - self._graph.pose(newest)[2])
        odometry_information = _rotated(_odometry_information(motion, path, turn), turned)
        key = (last, tuple(members))
        if self._local is None or self._local[0] != key:
            # only the surfaces facing where the scan is expected (the prior's sensor): a thin wall's far face, seen
            # from its other side, pulls the field and the lines (bench_slam_link_truth.py --facing; the closure
            # submaps keep every viewpoint's surfaces)
            viewpoint = np.array(compose(relative_prior, self._mount)[:2])
            self._local = (
                key,
                self._matcher(last, members, cfg.match_linear_window, viewpoint),
                self._views(last, members),
            )
        linear, angular = _match_window(odometry_information, cfg)
        # a point the window never saw (outside its scans' fields of view, beyond the clear range of a beam without a
        # return) is no evidence either way: scored as if it lay in clear space, it pulls the match to where the
        # window's surfaces end (a laser driven away from what it faces: the walls beside it are new, and every step
        # of the logs played backwards was matched 20-50 cm short); judged at the odometry prior, with the search
        # window's reach (linear + angular x the point's range) as margin
        margin = SEEN_MARGIN_CELLS * cfg.resolution + linear + angular * np.hypot(points[:, 0], points[:, 1])
        seen = _seen(transform_points(relative_prior, points), self._local[2], margin)
        return _LocalWindow(
            members, odometry_information, motion, path, turn, turned, self._local[1], linear, angular, seen, restarts
        )

    def _close_loops(self, node: int, events: list[str]) -> list[LoopClosure]:
        cfg = self.config
        pose = self._graph.pose(node)
        travelled = self._nodes[node].travelled
        poses = self._graph.poses
        candidates = [
            (math.hypot(*(poses[s.anchor, :2] - pose[:2])), i)
            for i, s in enumerate(self._submaps)
            if travelled - self._nodes[s.last].travelled >= cfg.loop_min_travel
        ]
        candidates = sorted((d, i) for d, i in candidates if d <= cfg.loop_search_radius)
        # the ones left over from the last updates first (their turn came), then the nearest
        queue = [i for i in self._pending if any(i == c for _, c in candidates)]
        queue += [i for _, i in candidates if i not in queue]
        self._pending = queue
        points = self._nodes[node].points
        closures: list[LoopClosure] = []
        marginals: list = []  # the graph's marginals, computed once an update when a candidate reaches its gate
        cap = CANDIDATE_WORK_CAP * 1e6
        # the update's time: a candidate is started, as the search ever was, only while the update's work is within
        # loop_work_budget (but one at least every other update, however busy the front end) and fewer than
        # loop_max_candidates are in progress; it is taken on while the work is within CANDIDATE_WORK_CAP, and what
        # is left of it waits for the next updates, which take the candidates in progress on after their own
        started = 0
        while self._pending and started < cfg.loop_max_candidates and len(points) >= MIN_BEAMS:
            if self._work.units > cfg.loop_work_budget * 1e6 and (started or not self._starved):
                break
            if len(self._candidates) >= cfg.loop_max_candidates:
                break
            i = self._pending.pop(0)
            started += 1
            self.searched_closures += 1
            prior = np.array(relative_pose(poses[self._submaps[i].anchor], pose))
            candidate = _Candidate(i, node, points, prior)
            while not self._step_candidate(candidate, closures, marginals):
                if self._work.units > cap:
                    self._candidates.append(candidate)
                    break
        if len(points) >= MIN_BEAMS:
            self._starved = started == 0 and bool(self._pending)
        stepped = started > 0
        while self._candidates and (self._work.units <= cap or not stepped):
            stepped = True  # a candidate in progress moves on however busy the update (its steps are bounded)
            candidate = self._candidates[0]
            if self._step_candidate(candidate, closures, marginals):
                self._candidates.pop(0)
        if closures:
            self._unoptimized += len(closures)
            chi = np.sqrt(self._graph.chi2()[-len(closures) :].max())
        if closures and (chi > OPTIMIZE_CHI or self._unoptimized >= OPTIMIZE_EVERY):
            self._unoptimized = 0
            self._start_optimization(events, drops=1)
        return closures

    def _slice(self, points: int) -> int:
        """Branch and bound nodes a search step may score: what is left of the update's CANDIDATE_WORK_CAP, at least
        MIN_SEARCH_SLICE (each node one lookup per point)."""
        left = CANDIDATE_WORK_CAP * 1e6 - self._work.units
        return max(MIN_SEARCH_SLICE, int(left / max(points, 1)))

    def _step_candidate(self, candidate: _Candidate, closures: list[LoopClosure], marginals: list) -> bool:
        """One step of a loop-closure candidate, its work counted; True once it is decided. The steps: the submap's
        matcher built, then its clear space (first search only); its window searched (a branch and bound scored a
        slice at a time: _slice); the match below loop_min_score or on the window's edge refused, else refined
        (_align); a match putting points in the clear space refused, else its rivals searched (a slice at a time,
        AMBIGUITY_MAX_NODES in all); an ambiguous match refused; the gate (the graph's marginals then, once an
        update) and the closure added (to `closures`). A step is about one slice, a build or the marginals: an
        update takes steps while within loop_work_budget, and the decision is the one a single update would take
        (the same searches), made once the last step is taken, on the graph then."""
        cfg = self.config
        submap = self._submaps[candidate.submap]
        points = candidate.points
        if submap.reference is None:
            if not self._hold_points(self._verified(self._submap_range(submap))):
                return True  # scans of nothing in reach (an open room's middle): no submap to match against
            self._reference_of(submap)
            return False
        if submap.reference.clear is None:
            self._clear_of(submap)
            return False
        if candidate.matched is None:
            if candidate.search is None:
                candidate.linear = self._closure_window(submap, candidate, marginals)
                candidate.search = WindowMatch(
                    submap.matcher, points, candidate.prior, candidate.linear, cfg.loop_angular_window
                )
            search = candidate.search
            before = search.nodes
            search.advance(self._slice(len(points)))
            self._work.add((search.nodes - before) * len(points))
            if not search.done:
                return False
            match = candidate.match = search.result()
            self._work.add(CANDIDATE_WORK)
            if match.score < cfg.loop_min_score or not np.all(np.isfinite(match.pose)):
                self.closure_outcomes.append((submap.anchor, candidate.node, "low score", match.pose))
                return True
            if _on_edge(match.pose, candidate.prior, cfg, candidate.linear):
                self.ambiguous_closures += 1  # the best of the window is on its edge: no peak, the best may lie beyond
                self.closure_outcomes.append((submap.anchor, candidate.node, "edge", match.pose))
                return True
            candidate.matched, candidate.aligned_information = _align(
                submap.reference, points, match.pose, cfg.resolution
            )
            return False
        if not candidate.unambiguous:
            if candidate.rival is None:
                if _clear_share(submap.reference.clear, points, candidate.matched) > LOOP_MAX_CLEAR_SHARE:
                    self.inconsistent_closures += 1
                    self.closure_outcomes.append((submap.anchor, candidate.node, "clear", candidate.matched))
                    return True
                # the gate first: a rival counts only where the graph's uncertainty would take it too
                gated = self._gate(submap, candidate, marginals)
                if gated is None:
                    self.rejected_closures += 1
                    self.closure_outcomes.append((submap.anchor, candidate.node, "gate", candidate.matched))
                    return True
                candidate.rival = _rival_search(
                    submap.matcher, points, candidate.matched, candidate.prior, cfg, gated, candidate.linear
                )
                if candidate.rival is None:  # the window leaves no room for a rival
                    candidate.unambiguous = True
                    return False
            rival = candidate.rival
            if not (rival.done or rival.nodes >= AMBIGUITY_MAX_NODES):
                before = rival.nodes
                rival.advance(min(self._slice(len(rival.points)), AMBIGUITY_MAX_NODES - rival.nodes))
                self._work.add((rival.nodes - before) * len(rival.points))
                if not (rival.done or rival.nodes >= AMBIGUITY_MAX_NODES):
                    return False
            found = rival.matches(refine=False, covariance_cells=0)
            if found and found[0].score >= AMBIGUITY_RATIO * candidate.match.score:
                self.ambiguous_closures += 1
                self.closure_outcomes.append((submap.anchor, candidate.node, "ambiguous", candidate.matched))
                return True
            candidate.unambiguous = True
            return False
        # the gate again, on the graph now (the rival search may have spanned updates)
        if self._gate(submap, candidate, marginals) is None:
            self.rejected_closures += 1
            self.closure_outcomes.append((submap.anchor, candidate.node, "gate", candidate.matched))
            return True
        covariance = self._closure_covariance(submap, points, candidate.matched, candidate.aligned_information)
        self.closure_outcomes.append((submap.anchor, candidate.node, "kept", candidate.matched))
        self._graph.add_edge(
            submap.anchor,
            candidate.node,
            candidate.matched,
            _information(_rotated(covariance, candidate.matched[2])),
            loop=True,
        )
        closures.append(LoopClosure(submap.anchor, candidate.node, float(candidate.match.score)))
        return True

    def _marginals(self, marginals: list):
        """The graph's marginals (PoseGraph.marginals), computed once an update (kept in `marginals`); None when its
        information cannot be factored (MappingError): a closure's window is then loop_linear_window and its gate
        takes nothing (the outcome "gate"), so that no closure's search raises out of `add`."""
        if not marginals:
            try:
                marginals.append(self._graph.marginals())
            except MappingError:
                marginals.append(None)
        return marginals[0]

    def _closure_window(self, submap: _Submap, candidate: _Candidate, marginals: list) -> float:
        """m, +- in x and y around the candidate's prior that its match searches: the region the gate would accept
        the closure in (LOOP_CHI2 of the graph's own uncertainty of the node relative to the anchor, times
        GATE_DRIFT_SCALE: its widest direction), at least loop_linear_window (the graph can claim less than it
        drifts: intel's right closures lay beyond that region's 3 sigma at 23 % of its candidates), and no wider
        than reaches the submap's field (beyond it every pose scores 0). A fixed window missed a return that the
        graph itself knew was metres uncertain: aces with every other scan (keyframes 1.4-2 m apart), seed 0, came
        back to its start 5.9-6.7 m off with a 3 sigma of 8.4 m, searched within 3 m, and ended 2.6 m off (ATE)."""
        graph = self._marginals(marginals)
        if graph is None:  # the graph's uncertainty unknown: the configured window
            return self.config.loop_linear_window
        relative = GATE_DRIFT_SCALE * self._relative_covariance(graph, submap.anchor, candidate.node)[:2, :2]
        widest = max(float(np.linalg.eigvalsh(0.5 * (relative + relative.T))[-1]), 0.0)
        reach = math.sqrt(LOOP_CHI2 * widest)
        if reach <= self.config.loop_linear_window:
            return self.config.loop_linear_window
        field = submap.matcher.score_map
        rows, cols = field.shape
        low = np.asarray(field.origin, dtype=float)
        high = low + field.resolution * np.array([cols, rows])
        prior = candidate.prior[:2]
        extent = float(max(np.max(np.abs(low - prior)), np.max(np.abs(high - prior))))
        return max(self.config.loop_linear_window, min(reach, extent))

    def _gate(self, submap: _Submap, candidate: _Candidate, marginals: list) -> tuple[np.ndarray, np.ndarray] | None:
        """The closure against the poses now: its covariance plus the graph's own uncertainty of the anchor -> node
        relative pose (every edge, closures included: a closure found earlier shortens it; the marginals computed
        once an update, in `marginals`). None beyond LOOP_CHI2; else where the graph puts the node in the anchor's
        frame (x, y) and that position's information (2 x 2: the spread's x-y block inverted), the region a rival
        must lie in to be one (_rival_search)."""
        anchor = self._graph.pose(submap.anchor)
        predicted = np.array(relative_pose(anchor, self._graph.pose(candidate.node)))
        innovation = candidate.matched - predicted
        innovation[2] = wrap_angle(innovation[2])
        graph = self._marginals(marginals)
        if graph is None:  # no uncertainty to weigh the closure against: not taken
            return None
        covariance = self._closure_covariance(
            submap, candidate.points, candidate.matched, candidate.aligned_information
        )
        relative = self._relative_covariance(graph, submap.anchor, candidate.node)
        spread = covariance + GATE_DRIFT_SCALE * relative
        chi2 = float(innovation @ np.linalg.solve(spread, innovation))
        if not chi2 <= LOOP_CHI2:
            return None
        return predicted[:2], np.linalg.inv(spread[:2, :2])

    def _start_optimization(self, events: list[str], drops: int) -> None:
        """A new optimization run (the one in progress, if any, is superseded: it starts again from the poses it
        reached, its kernel as wide as the closures now need); it may remove `drops` closures at its end."""
        try:
            self._run = self._graph.optimization(ONLINE_ITERATIONS)
            self._drops = drops
        except MappingError as error:
            self._run = None
            events.append(f"loop closure optimization failed, poses kept: {error}")

    def _advance_optimization(self, node: int, events: list[str]) -> None:
        """The optimization in progress taken on: iterations (each OPTIMIZE_WORK_PER_EDGE an edge) while they
        stay within OPTIMIZE_BUDGET, one at least; when it is done, the closure the
        optimized graph disagrees with most is removed if beyond LOOP_RESIDUAL_CHI2 (_drop_worst), and a new run
        started to optimize without it. The new node's pose and the front end's submap follow the poses."""
        if self._run is None:
            return
        before = self._graph.pose(node)
        iterations, spent = 0, 0.0
        try:
            while self._run is not None:
                cost = OPTIMIZE_WORK_PER_EDGE * self._graph.edge_count
                if iterations and spent + cost > OPTIMIZE_BUDGET:
                    break
                if not self._run.done:
                    solves = self._run.solves
                    self._run.step(1)
                    iterations += 1
                    spent += cost * (self._run.solves - solves)
                    self._work.add(cost * (self._run.solves - solves))
                if not self._run.done:
                    continue
                result = self._run.result()
                events.append(
                    f"loop closure optimization: {result.iterations} iterations, moved up to {result.max_change:.2f}"
                )
                self._run = None
                if self._drops > 0 and self._drop_worst(events):
                    self._start_optimization(events, self._drops - 1)
        except MappingError as error:
            self._run = None
            events.append(f"loop closure optimization failed, poses kept: {error}")
        self._pose = self._graph.pose(node)
        if not np.allclose(before, self._pose):
            self._local = None  # rebuilt at the optimized poses

    def _optimize(self, max_iterations: int, events: list[str], drops: int = 3):
        """The graph optimized, then the loop closures checked against it: the closure whose residual's
        chi-square is largest, if above LOOP_RESIDUAL_CHI2, disagrees with the other closures and the scan
        matches together (the kernel turned it down, it did not bend the graph to fit): it is removed and the
        graph optimized again, at most `drops` times a call (one online: an update's time). MappingError from the
        optimizer passes through."""
        result = self._graph.optimize(max_iterations=max_iterations)
        for _ in range(drops):
            if not self._drop_worst(events):
                break
            moved = result.max_change
            result = self._graph.optimize(max_iterations=max_iterations)
            result = dataclasses.replace(result, max_change=max(moved, result.max_change))
        return result

    def _drop_worst(self, events: list[str]) -> bool:
        """Removes the loop closure whose residual's chi-square is largest, if above LOOP_RESIDUAL_CHI2 (see
        _optimize); returns whether one was."""
        loop = np.flatnonzero(self._graph.loop)
        if len(loop) == 0:
            return False
        chi2 = self._graph.chi2()[loop]
        worst = int(np.argmax(chi2))
        if not chi2[worst] > LOOP_RESIDUAL_CHI2:
            return False
        i, j = self._graph.edges[loop[worst]]
        self._graph.remove_edges([loop[worst]])
        self.dropped_closures += 1
        events.append(
            f"loop closure ({i}, {j}) disagrees with the optimized graph (chi-square {chi2[worst]:.0f} > "
            f"{LOOP_RESIDUAL_CHI2}): removed"
        )
        return True

    def _closure_covariance(
        self, submap: _Submap, points: np.ndarray, matched: np.ndarray, aligned_information: np.ndarray | None
    ) -> np.ndarray:
        """A closure's covariance (the anchor's frame): the point-to-line refinement's (its normal equations over
        its residuals' variance, at CLOSURE_INFORMATION_SHARE; the match's curvature and the field's quantization where
        it found too few pairs)
        plus the submap's layout (_layout_covariance: its members placed by the scan matches between them, the
        anchor one of them), carried to where the match put the node."""
        if aligned_information is None:
            information = _match_information(submap.matcher, points, matched, self.config.resolution)
            covariance = np.linalg.inv(_with_quantization(information, points, self.config.resolution))
        else:
            covariance = np.linalg.inv(_clamped(aligned_information)) / CLOSURE_INFORMATION_SHARE
        lever = np.array([[1.0, 0.0, -matched[1]], [0.0, 1.0, matched[0]], [0.0, 0.0, 1.0]])
        return covariance + lever @ submap.layout @ lever.T

    def _relative_covariance(self, marginals, first: int, last: int) -> np.ndarray:
        """Covariance (first's frame) of node last's pose relative to node first's, from the graph's joint
        covariance of the two (marginals)."""
        joint = marginals.covariance([first, last])
        a, b = self._graph.pose(first), self._graph.pose(last)
        c, s = math.cos(a[2]), math.sin(a[2])
        dx, dy = b[0] - a[0], b[1] - a[1]
        jacobian = np.array(
            [
                [-c, -s, -s * dx + c * dy, c, s, 0.0],
                [s, -c, -c * dx - s * dy, -s, c, 0.0],
                [0.0, 0.0, -1.0, 0.0, 0.0, 1.0],
            ]
        )
        return jacobian @ joint @ jacobian.T


def _information(covariance: np.ndarray) -> np.ndarray:
    """An edge's information from its covariance (the error's frame), its standard deviations at least
    MIN_EDGE_SIGMA (added in quadrature); a covariance that is not finite: a standard deviation of 100 m / rad."""
    covariance = np.asarray(covariance, dtype=float)
    if covariance.shape != (3, 3) or not np.all(np.isfinite(covariance)):
        return np.eye(3) * 1e-4
    floor = np.square([MIN_EDGE_SIGMA[0], MIN_EDGE_SIGMA[0], MIN_EDGE_SIGMA[1]])
    information = np.linalg.inv(0.5 * (covariance + covariance.T) + np.diag(floor))
    return 0.5 * (information + information.T)


def _rotated(covariance: np.ndarray, heading: float) -> np.ndarray:
    """A covariance of a pose in its reference's frame carried to the pose's own frame (the graph's error frame: the
    measured node's), the pose's heading `heading` in the reference's."""
    c, s = math.cos(heading), math.sin(heading)
    rotation = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return rotation @ covariance @ rotation.T


def _fused_covariance(*estimates) -> np.ndarray:
    """The covariance of the information-weighted mean of independent estimates, each (weight, covariance): the
    weights are the estimator's, the covariances the estimates' own (they differ where an estimate is weighed at
    less than its information: ALIGN_WEIGHT_SHARE)."""
    total = sum(weight for weight, _ in estimates)
    covariance = np.zeros((3, 3))
    for weight, own in estimates:
        gain = np.linalg.solve(total, weight)
        covariance += gain @ own @ gain.T
    return 0.5 * (covariance + covariance.T)


def _layout_covariance(poses: np.ndarray, links: np.ndarray, anchor: int) -> np.ndarray:
    """How far a submap's points may be off as a rigid motion (u, w: p -> p + u + w (-p_y, p_x)) in the anchor's frame,
    at its origin: its members (poses (M, 3), in order) stand where the scan matches between them put them, the anchor
    (index `anchor`) fixed, so an error of link k (links (M - 1, 3, 3): the covariance of edge (k - 1, k), node k's
    frame) moves the members beyond it, away from the anchor, rigidly about node k. A scan matched to the submap sees
    part of it, which members not known: each member's motion's covariance, averaged over the members (the motion
    averaged over them, as if the scan fitted all alike, said a quarter to a half of it: loops seed 1's closures 2-3
    cm off at 3 mm, chi-square 20 mean and 6 median at the truth, 12 and 2.7 so)."""
    count = len(poses)
    origin = poses[anchor]
    covariance = np.zeros((3, 3))
    for k in range(1, count):
        x, y, theta = relative_pose(origin, poses[k])
        c, s = math.cos(theta), math.sin(theta)
        # node k's link error (dt in k's frame, dtheta) as a motion of the members beyond it about node k
        gain = np.array([[c, -s, y], [s, c, -x], [0.0, 0.0, 1.0]])
        share = (count - k) / count if k > anchor else k / count
        covariance += share * (gain @ links[k - 1] @ gain.T)
    return covariance


def _rival_search(
    matcher: CorrelativeMatcher,
    points: np.ndarray,
    pose: np.ndarray,
    prior: np.ndarray,
    config: SlamConfig,
    gated: tuple[np.ndarray, np.ndarray] | None = None,
    window: float | None = None,
) -> GlobalSearch | None:
    """The search (GlobalSearch, resumable: GraphSlam takes it a slice at a time, AMBIGUITY_MAX_NODES nodes in all)
    for the best score of the scan anywhere in the closure's search window (+-`window` m of the prior, by default
    loop_linear_window; any heading) at least AMBIGUITY_DISTANCE from the match; None when the window leaves no room
    for one. A corridor, a row of equal rooms, a maze's cells one pitch apart match nearly as well there, and a
    closure to one of them says little about which; rivals only along the match's principal axes and 0.5 m off let
    0.45-1.5 m false closures through in generated mazes (the pitch 0.44 m, its diagonal 0.62 m). Pruned at the
    match's own score instead (a rival below AMBIGUITY_RATIO of it is no rival) it saved little on fhw and changed the
    budgeted search's answers: perfect seed 0 mapped 0.85 precise, 0.94 as it is."""
    score_map = matcher.score_map
    rows, cols = score_map.shape
    res = score_map.resolution
    x = score_map.origin[0] + (np.arange(cols) + 0.5) * res
    y = score_map.origin[1] + (np.arange(rows) + 0.5) * res
    window = config.loop_linear_window if window is None else window
    in_x = np.abs(x - prior[0]) <= window
    in_y = np.abs(y - prior[1]) <= window
    region = in_y[:, None] & in_x[None, :]
    region &= np.hypot(x[None, :] - pose[0], y[:, None] - pose[1]) >= AMBIGUITY_DISTANCE
    if gated is not None:  # only where the graph's uncertainty would put the node too (RIVAL_CHI2)
        centre, information = gated
        dx, dy = x[None, :] - centre[0], y[:, None] - centre[1]
        region &= information[0, 0] * dx * dx + 2.0 * information[0, 1] * dx * dy + information[1, 1] * dy * dy <= (
            RIVAL_CHI2
        )
    if not region.any():
        return None
    return GlobalSearch(
        matcher,
        points,
        region,
        count=1,
        min_score=min(1.0, AMBIGUITY_RATIO * config.loop_min_score),
        min_separation=AMBIGUITY_DISTANCE,
    )


def _rival_score(
    matcher: CorrelativeMatcher,
    points: np.ndarray,
    pose: np.ndarray,
    prior: np.ndarray,
    config: SlamConfig,
    work: _Work | None = None,
    gated: tuple[np.ndarray, np.ndarray] | None = None,
) -> float:
    """The best score of a rival of the match (_rival_search) in one go: 0 if none."""
    search = _rival_search(matcher, points, pose, prior, config, gated)
    if search is None:
        return 0.0
    found = search.step(AMBIGUITY_MAX_NODES, refine=False)
    if work is not None:
        work.add(search.nodes * len(search.points))
    return float(found[0].score) if found else 0.0


def _on_edge(pose: np.ndarray, prior: np.ndarray, config: SlamConfig, window: float | None = None) -> bool:
    """Whether a loop-closure match lies on the edge of its search window (+-`window` m in x and y, by default
    loop_linear_window: within EDGE_CELLS cells of its side, or EDGE_ANGLE of the angular one's): a maximum there is
    the window's, not the score's (loops seed 2: a look-alike corridor 3.1 m off, at the +-3 m window's side, taken,
    the true place in the middle scoring less)."""
    linear = (config.loop_linear_window if window is None else window) - EDGE_CELLS * config.resolution
    angular = config.loop_angular_window - EDGE_ANGLE
    offset = np.abs(np.asarray(pose[:2], dtype=float) - prior[:2])
    return bool(offset.max() >= linear or abs(wrap_angle(float(pose[2] - prior[2]))) >= angular)


def _posterior_mode(
    matcher: CorrelativeMatcher,
    points: np.ndarray,
    match,
    prior: np.ndarray,
    odometry_information: np.ndarray,
    window: tuple[float, float],
    work: _Work | None = None,
):
    """The match that maximizes the posterior over the window, the scan's likelihood (MATCH_INFORMATION_SCALE
    times the mean score: the scale of _match_information) times the odometry prior, not the likelihood alone
    (Olson 2009). Along a corridor the best score lies anywhere a door or a corner lines up: on aces the best
    pose of the window was 0.3-0.47 m off along the corridor at scans 25-29 (0.814 against 0.793 at the true
    pose), the posterior's 3-8 cm. Only a mode within the odometry's penalty of the best score can win, so the
    window is searched for modes (window_modes, budgeted, counted) only when the match is that far off the
    prior, and down to that score, AMBIGUITY_DISTANCE or more from the match (the match's own peak is left to the
    Gaussian fusion with the odometry, which would otherwise count the prior twice); the winner is matched again
    within two cells and steps."""
    if not np.all(np.isfinite(match.pose)):
        return match

    def penalty(pose) -> float:
        return _odometry_penalty(pose, prior, odometry_information)

    best_score = matcher.score(points, match.pose)
    margin = penalty(match.pose) / MATCH_INFORMATION_SCALE
    if margin < POSTERIOR_MIN_MARGIN:
        return match
    modes = window_modes(
        matcher,
        points,
        prior,
        window[0],
        window[1],
        count=POSTERIOR_MODES,
        min_score=float(np.clip(best_score - margin, 0.0, 1.0)),
        min_separation=POSTERIOR_SEPARATION_CELLS * matcher.resolution,
        min_angle_separation=window[1],
        exclude=(float(match.pose[0]), float(match.pose[1]), AMBIGUITY_DISTANCE),
        max_nodes=LOCAL_RIVAL_MAX_NODES,
    )
    if work is not None:
        work.add(modes.nodes * len(points))
    value = MATCH_INFORMATION_SCALE * best_score - penalty(match.pose)
    chosen = None
    for found in modes.matches:
        candidate = MATCH_INFORMATION_SCALE * found.score - penalty(found.pose)
        if candidate > value:
            value, chosen = candidate, found
    if chosen is None:
        return match
    step = default_angular_step(points, matcher.resolution)
    again = matcher.match(points, chosen.pose, 2.0 * matcher.resolution, 2.0 * step)
    if work is not None:
        work.add(again.nodes * len(points))
    return again


def _weak_match(
    matcher: CorrelativeMatcher,
    points: np.ndarray,
    match,
    matched: np.ndarray,
    information: np.ndarray,
    prior: np.ndarray,
    odometry_information: np.ndarray,
    events: list[str],
    window: tuple[float, float],
    work: _Work | None = None,
) -> np.ndarray | None:
    """A weak front-end match (below WEAK_MATCH_SCORE) tested: its information widened towards a rival mode in the
    window (_local_rival) by the rival's share of the two modes' posterior (_rival_share), then None (not used:
    the node goes on odometry alone) if its offset from the odometry prior, against both covariances, is beyond
    MATCH_CHI2. window: (+-m, +-rad) around the prior, the match's own. Each outcome is said in `events`."""
    rival = _local_rival(matcher, points, matched, prior, window[0], window[1], match.score, work)
    if rival is not None:
        spread = rival - matched
        spread[2] = wrap_angle(spread[2])
        share = _rival_share(matcher, points, match.pose, rival, prior, odometry_information)
        information = _clamped(np.linalg.inv(np.linalg.inv(information) + share * np.outer(spread, spread)))
        events.append(
            f"scan match {match.score:.2f} has a rival {np.hypot(*spread[:2]):.2f} m, "
            f"{math.degrees(spread[2]):.0f} deg off at posterior share {share:.2g}: the mode widened by it"
        )
    offset = prior - matched
    offset[2] = wrap_angle(offset[2])
    chi2 = float(offset @ np.linalg.solve(np.linalg.inv(information) + np.linalg.inv(odometry_information), offset))
    if not chi2 <= MATCH_CHI2:
        events.append(
            f"scan match (score {match.score:.2f}) disagrees with the odometry (chi-square {chi2:.1f} > "
            f"{MATCH_CHI2}): node added on odometry alone"
        )
        return None
    return information


def _odometry_penalty(pose, prior: np.ndarray, odometry_information: np.ndarray) -> float:
    """The odometry prior's negative log-density at pose (up to a constant): half its Mahalanobis distance squared,
    the heading's offset wrapped. How the front end weighs a mode against the odometry."""
    offset = np.asarray(pose, dtype=float) - prior
    offset[2] = wrap_angle(offset[2])
    return 0.5 * float(offset @ odometry_information @ offset)


def _rival_share(
    matcher: CorrelativeMatcher,
    points: np.ndarray,
    pose: np.ndarray,
    rival: np.ndarray,
    prior: np.ndarray,
    odometry_information: np.ndarray,
) -> float:
    """The rival mode's share of the two modes' posterior, each weighed as _posterior_mode weighs modes (the scan's
    likelihood, MATCH_INFORMATION_SCALE times the score, times the odometry prior): the second moment of the
    two-mode mixture about the match is its own covariance plus share * spread spread^T (the rival taken as certain,
    share 1, put a rival 38 deg off as likely as the match, and the fused pose between the two where neither the scan
    nor the odometry is: orebro's scan 213)."""

    def log_posterior(candidate) -> float:
        score = matcher.score(points, candidate)
        return MATCH_INFORMATION_SCALE * score - _odometry_penalty(candidate, prior, odometry_information)

    return float(expit(log_posterior(rival) - log_posterior(pose)))  # the logistic, without overflow either way


def _local_rival(
    matcher: CorrelativeMatcher,
    points: np.ndarray,
    pose: np.ndarray,
    prior: np.ndarray,
    linear: float,
    angular: float,
    score: float,
    work: _Work | None = None,
) -> np.ndarray | None:
    """The best pose within the front end's window (+-linear of the prior in x and y, +-angular in heading) at
    least AMBIGUITY_DISTANCE from the match that scores LOCAL_RIVAL_RATIO of its score or more; None if none
    (amr_maps.window_search.window_modes: a budgeted branch and bound over the window's lattice less the match's
    own AMBIGUITY_DISTANCE)."""
    modes = window_modes(
        matcher,
        points,
        prior,
        linear,
        angular,
        count=5,
        min_score=min(1.0, LOCAL_RIVAL_RATIO * score),
        min_separation=AMBIGUITY_DISTANCE,
        min_angle_separation=angular,
        exclude=(float(pose[0]), float(pose[1]), AMBIGUITY_DISTANCE),
        max_nodes=LOCAL_RIVAL_MAX_NODES,
    )
    if work is not None:
        work.add(modes.nodes * len(points))
    for found in modes.matches:
        # a mode of its own: the score dips between it and the match (else it is the match's own slope, which
        # the match's information already has)
        rival = np.asarray(found.pose, dtype=float)
        middle = pose + 0.5 * np.array([*(rival[:2] - pose[:2]), wrap_angle(rival[2] - pose[2])])
        if matcher.score(points, middle) < RIVAL_DIP * min(found.score, score):
            return rival
    return None


def makes_node(delta, config: SlamConfig) -> bool:
    """Whether odometry's motion `delta` (x, y, theta) since the last node makes a scan a node: update_min_d of travel
    or update_min_a of turn."""
    return bool(math.hypot(delta[0], delta[1]) >= config.update_min_d or abs(delta[2]) >= config.update_min_a)


def _seen(points: np.ndarray, views, margin) -> np.ndarray:
    """Which points (K, 2) some view saw: a view (sensor pose, ascending beam angles, reach) saw a point whose
    bearing b lies between two beams (angle[i] <= b <= angle[i + 1]) within 0.75 of the median spacing of one of
    them (a dropped beam's gap is not seen) and whose range is at most the two beams' reach plus `margin` (m, or
    one a point): r <= max(reach[i], reach[i + 1]) + margin."""
    seen = np.zeros(len(points), dtype=bool)
    for sensor, angles, reach in views:
        if len(angles) < 2:
            continue
        local = transform_points(inverse(sensor), points)
        r = np.hypot(local[:, 0], local[:, 1])
        bearing = np.arctan2(local[:, 1], local[:, 0])
        # the bearing unwrapped to the beams' span (a 360-degree scan's first and last beams are neighbours)
        bearing = angles[0] + np.mod(bearing - angles[0], 2.0 * math.pi)
        spacing = float(np.median(np.diff(angles)))
        i = np.clip(np.searchsorted(angles, bearing), 1, len(angles) - 1)
        gap = np.minimum(bearing - angles[i - 1], np.abs(angles[i] - bearing))
        within = gap <= 0.75 * spacing  # a dropped beam's gap (NaN, too close) is not seen
        seen |= within & (r <= np.maximum(reach[i - 1], reach[i]) + margin)
    return seen


def _window_reference(
    cloud: np.ndarray, sensors: np.ndarray, resolution: float, window: float, viewpoint=None
) -> _Reference:
    """What a scan is matched against, made of a window's points (cloud, each seen from its sensor: (K, 2) both, the
    anchor's frame): the correlative matcher on their likelihood field, window + LIKELIHOOD_PAD m around them, and
    their voxel means with the local lines for the refinement; with a viewpoint (where the scan is expected to be
    taken), only the points on surfaces facing it (_facing)."""
    if viewpoint is not None:
        cloud = cloud[_facing(cloud, sensors, viewpoint, resolution)]
    score_map = ScoreMap.from_points(
        cloud,
        resolution,
        LIKELIHOOD_SIGMA_CELLS * resolution,
        window + LIKELIHOOD_PAD,
        cover=np.zeros((1, 2)),
        to_points=True,
    )
    means = _voxel_means(cloud, ALIGN_VOXEL_CELLS * resolution)
    lines = _lines(means, cloud, ALIGN_NEIGHBOURHOOD_CELLS * resolution)
    return _Reference(CorrelativeMatcher(score_map), means, *lines, cKDTree(means))


def _match_window(odometry_information: np.ndarray, config: SlamConfig) -> tuple[float, float]:
    """(m, rad): the front end's search window, WINDOW_SIGMAS standard deviations of the odometry model, at least two
    cells, at most match_linear_window / match_angular_window."""
    sigma = np.sqrt(np.diag(np.linalg.inv(odometry_information)))
    linear = min(config.match_linear_window, max(2.0 * config.resolution, WINDOW_SIGMAS * max(sigma[0], sigma[1])))
    return linear, min(config.match_angular_window, WINDOW_SIGMAS * sigma[2])


def _fused(matched: np.ndarray, match_information: np.ndarray, prior: np.ndarray, odometry_information: np.ndarray):
    """The match and the odometry prior as two Gaussians on the pose in the anchor's frame (the odometry's
    information in the anchor's frame too): their product's mean."""
    offset = prior - matched
    offset[2] = wrap_angle(offset[2])
    return matched + np.linalg.solve(match_information + odometry_information, odometry_information @ offset)


def _facing(cloud: np.ndarray, sensors: np.ndarray, viewpoint, resolution: float) -> np.ndarray:
    """Which of the cloud's points (each seen from its sensor, (K, 2) both) lie on a surface facing the viewpoint:
    the local line's normal (ALIGN_NEIGHBOURHOOD_CELLS around the point) has the point's own sensor and the
    viewpoint on the same side. A thin wall's far face, seen by earlier scans from the other side, is not where the
    viewpoint's scan can have its points; where no line is found (a corner, a lone point) the point is kept."""
    means, group = _voxels(cloud, ALIGN_VOXEL_CELLS * resolution)
    normals = _lines(means, cloud, ALIGN_NEIGHBOURHOOD_CELLS * resolution)[1][group]
    own = np.einsum("ki,ki->k", normals, sensors - cloud)
    seen = np.einsum("ki,ki->k", normals, np.asarray(viewpoint, dtype=float)[None, :] - cloud)
    return ~(own * seen < 0.0)


def _voxel_means(points: np.ndarray, size: float) -> np.ndarray:
    """The mean of the points in each square of `size` m that holds any."""
    return _voxels(points, size)[0]


def _voxels(points: np.ndarray, size: float) -> tuple[np.ndarray, np.ndarray]:
    """(means, group): the mean of the points in each square of `size` m that holds any, and each point's square
    (its row of means)."""
    cells = np.floor(points / size).astype(np.int64)
    cells -= cells.min(axis=0)
    # one key per square, in the rows' lexicographic order (np.unique(axis=0)'s, several times slower)
    _, group = np.unique(cells[:, 0] * (int(cells[:, 1].max()) + 1) + cells[:, 1], return_inverse=True)
    group = group.reshape(-1)
    count = np.bincount(group)
    means = np.column_stack(
        [np.bincount(group, weights=points[:, 0]) / count, np.bincount(group, weights=points[:, 1]) / count]
    )
    return means, group


def _lines(means: np.ndarray, points: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(centres, normals): each mean's neighbourhood (the points within `reach` m, at most ALIGN_NEIGHBOURS) as a
    line: its centroid and unit normal (principal axes); normals NaN where fewer than ALIGN_MIN_NEIGHBOURS are
    that close or they do not lie along a line (ALIGN_FLATNESS: a corner, a lone point). See
    amr_mapping.point_field.neighbourhood_lines."""
    return neighbourhood_lines(means, points, reach, ALIGN_NEIGHBOURS, ALIGN_MIN_NEIGHBOURS, ALIGN_FLATNESS)


def _align(
    reference: _Reference, points: np.ndarray, pose: np.ndarray, resolution: float
) -> tuple[np.ndarray, np.ndarray | None]:
    """The correlative match refined by point-to-line ICP (robust weights, Gauss-Newton) against the reference's
    points: the likelihood field's peak is flat over walls a few cells thick (noisy points, rasterized to cell
    centres), so the match alone was 1-1.5 cm and 0.7-1 deg off even against a submap at the true poses; the
    lines through the points themselves are not. Only the directions the lines constrain are moved (a corridor's
    length is left to the match), at most ALIGN_DISTANCE_CELLS cells and an equal turn at the scan's mean range
    from the match; too few pairs: the match as it is. Returns (pose, information): the Gauss-Newton information,
    the lines' normal equations at the pose over the residuals' variance (the LiDAR's noise, the lines' own error and
    the reference's layout as far as they scatter the residuals), None when not refined."""
    pose = np.asarray(pose, dtype=float)
    reach = ALIGN_DISTANCE_CELLS * resolution
    radius = max(float(np.mean(np.hypot(points[:, 0], points[:, 1]))), resolution)
    limit = np.array([reach, reach, reach / radius])
    current = pose.copy()
    for _ in range(ALIGN_ITERATIONS):
        c, s = math.cos(current[2]), math.sin(current[2])
        moved = transform_points(current, points)
        distances, nearest = reference.tree.query(moved, distance_upper_bound=reach)
        paired = np.isfinite(distances)
        paired[paired] = np.isfinite(reference.normals[nearest[paired], 0])
        if paired.sum() < ALIGN_MIN_PAIRS:
            return pose, None
        normal = reference.normals[nearest[paired]]
        residual = np.einsum("ki,ki->k", moved[paired] - reference.centres[nearest[paired]], normal)
        local = points[paired]
        turn = normal[:, 0] * (-s * local[:, 0] - c * local[:, 1]) + normal[:, 1] * (c * local[:, 0] - s * local[:, 1])
        jacobian = np.column_stack([normal[:, 0], normal[:, 1], turn])
        weight = 1.0 / (1.0 + (residual / (0.5 * resolution)) ** 2)  # Cauchy: a stray pair weighs little
        hessian = jacobian.T @ (weight[:, None] * jacobian)
        gradient = jacobian.T @ (weight * residual)
        values, vectors = np.linalg.eigh(hessian)
        keep = values > ALIGN_EIGEN_RATIO * max(values[-1], 1e-12)
        step = -vectors[:, keep] @ ((vectors[:, keep].T @ gradient) / values[keep])
        current = pose + np.clip(current + step - pose, -limit, limit)
        if abs(step[0]) < 1e-4 * resolution and abs(step[1]) < 1e-4 * resolution and abs(step[2]) < 1e-5:
            break
    variance = max(float(weight @ residual**2) / max(float(weight.sum()), 1e-9), ALIGN_MIN_SIGMA**2)
    return current, hessian / variance


def _refined(
    reference: _Reference, points: np.ndarray, pose: np.ndarray, resolution: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pose, weight, covariance) of a scan matched at `pose` (the correlative match, refined on the bilinear field):
    the match and its point-to-line refinement (_align) as two estimates of one pose, each weighted by its information
    (_match_information: the score's curvature, with the field's quantization; _align's: its normal equations over
    its residuals' spread, at ALIGN_WEIGHT_SHARE). Where the lines explain the scan to a millimetre (a simulated maze:
    straight walls, the field's top flat over a wall's cells) the refinement decides; where they do not (real logs:
    clutter, a SICK's 1-degree beams; its residuals 1-2 cm, its heading sigma twice the match's on aces) the match
    does. Taking the refinement whatever its information cost the logs (front end against submaps at the reference
    poses, aces: heading error 0.40 deg mean with it, 0.26 without, 0.28 weighted). weight: the more informative
    estimate's weight (largest determinant; both come from the same scan), what the odometry is weighed against;
    covariance: that estimate's own: the refinement's Gauss-Newton covariance (not at ALIGN_WEIGHT_SHARE: chi-square
    3-7 at the true poses of recorded maze runs, 0.2-0.3 at the share), or the match's (its curvature and the field's
    quantization: 0.2-0.8 in the mazes, where it seldom decides; on the logs, where it does, the refinement's said
    a twentieth of the links' error against the corrected poses and broke fhw: ATE 0.16 -> 0.75 m)."""
    information = _match_information(reference.matcher, points, pose, resolution)
    information = _with_quantization(information, points, resolution)
    aligned, aligned_information = _align(reference, points, pose, resolution)
    if aligned_information is None:
        return np.asarray(pose, dtype=float), information, np.linalg.inv(information)
    information = _constrained(information, reference, points, pose, resolution)
    weight = _clamped(ALIGN_WEIGHT_SHARE * aligned_information)
    step = aligned - pose
    step[2] = wrap_angle(step[2])
    fused = pose + np.linalg.solve(information + weight, weight @ step)
    if np.linalg.det(weight) <= np.linalg.det(information):
        return fused, information, np.linalg.inv(information)
    return fused, weight, np.linalg.inv(_clamped(aligned_information))


def _constrained(
    information: np.ndarray, reference: _Reference, points: np.ndarray, pose: np.ndarray, resolution: float
) -> np.ndarray:
    """A correlative match's information (at pose, the anchor's frame) without the directions the surfaces under the
    scan do not constrain (Zhang, Kaess and Singh 2016, degeneracy in optimization-based estimation): each scan point
    within CONSTRAINT_REACH_CELLS of a reference point on a line constrains the pose along that line's normal only
    (point-to-line); a direction their normal equations (the heading scaled by the points' RMS range) weigh below
    ALIGN_EIGEN_RATIO of the strongest is left to the odometry. The score's curvature there is not the world's: it
    comes from where the window's points end and from a wall's dots seen at a grazing angle (open_room 3: one wall in
    the LDS's 3.5 m, the match 2.1 cm along it, the odometry's 4 cm outweighed, the nodes slid back 0.4 m over
    1.1 m; generated corridors facing the way: steps 0.2-0.5 m short). Points with no line under them (corners, lone
    points, a window's thin edge) are left out of the test: at a window's edge they claim the along-wall information
    that is not there. _align's own pairs (two cells) are not the test: on orebro's 3 m keyframes they were 29
    points at 1 m of 181 out to 7 m, a heading the rest of the scan fixes."""
    moved = transform_points(pose, points)
    distances, nearest = reference.tree.query(moved, distance_upper_bound=CONSTRAINT_REACH_CELLS * resolution)
    near = np.isfinite(distances)
    near[near] = np.isfinite(reference.normals[nearest[near], 0])
    if near.sum() < ALIGN_MIN_PAIRS:  # too few points on lines to judge: the match as it is
        return information
    normals = reference.normals[nearest[near]]
    local = moved[near] - np.asarray(pose[:2], dtype=float)
    radius = max(float(np.sqrt(np.mean(np.sum(local**2, axis=1)))), resolution)
    lever = np.column_stack([-local[:, 1], local[:, 0]]) / radius  # d(point)/d(theta) at the RMS range's scale
    jacobian = np.column_stack([normals, np.einsum("ki,ki->k", normals, lever)])
    values, vectors = np.linalg.eigh(jacobian.T @ jacobian)
    free = vectors[:, values <= ALIGN_EIGEN_RATIO * max(values[-1], 1e-12)]
    if free.shape[1] == 0:
        return information
    scale = np.array([1.0, 1.0, radius])
    normalized = information / np.outer(scale, scale)
    projector = np.eye(3) - free @ free.T
    return _clamped(projector @ normalized @ projector * np.outer(scale, scale))


def _with_quantization(information: np.ndarray, points: np.ndarray, resolution: float) -> np.ndarray:
    """A correlative match's information with the field's quantization added to its covariance: the field is a
    table of cells (exact at their centres, interpolated between), so the match is uncertain by a cell's
    res / sqrt(12) in x and y however sharp its score, and in heading by that much at the points' RMS range (0.8 deg
    at 1 m: a maze's short ranges, where the refinement on the walls' lines is the better estimate; 0.2 deg at 4
    m). Without it the match outweighed the refinement in the mazes (loops seed 1: precise 0.98 -> 0.85)."""
    radius = max(float(np.sqrt(np.mean(np.sum(points**2, axis=1)))), resolution) if len(points) else 1.0
    q = resolution / math.sqrt(12.0)
    covariance = np.linalg.inv(information) + np.diag([q * q, q * q, (q / radius) ** 2])
    return np.linalg.inv(covariance)


def _clear_share(clear: OccupancyGrid | None, points: np.ndarray, pose: np.ndarray) -> float:
    """The share of the points (robot frame) at pose (the grid's frame) that land in clear cells."""
    if clear is None or len(points) == 0:
        return 0.0
    x, y = transform_points(pose, points).T
    rows, cols = clear.world_to_cell(x, y)
    rows, cols = np.asarray(rows, dtype=int), np.asarray(cols, dtype=int)
    inside = (rows >= 0) & (rows < clear.height) & (cols >= 0) & (cols < clear.width)
    return float((clear.data[rows[inside], cols[inside]] > 0).sum()) / len(points)


def _odometry_information(delta, path: float | None = None, turn: float | None = None) -> np.ndarray:
    """The odometry model's information (_odometry_model) for a motion delta (dx, dy, dtheta; the frame it starts
    in), over `path` m and `turn` rad (their sums over the steps: by default the delta's own)."""
    return np.linalg.inv(_odometry_model(delta, path, turn))


def _odometry_model(delta, path=None, turn=None, share_xy: float = 1.0, share_theta: float = 1.0) -> np.ndarray:
    """The covariance (the frame the motion starts in) of odometry's error over a motion delta (dx, dy, dtheta),
    `path` m driven and `turn` rad turned (by default the delta's own), the standard deviations at share_xy /
    share_theta (the robot's own error: SlamConfig.odometry_error_xy / _theta; 1: the model, the front end's prior):
    ODOMETRY_SIGMA's position error, isotropic, the translation's error per radian turned along the line of travel
    (the motion model's trans, which the turns' noise lengthens or shortens), and heading error, half of it
    made before the translation, so that it turns the whole of it (the motion model's rot1, trans, rot2:
    Probabilistic Robotics, table 5.6): the position off sideways by d e_1 (variance d^2 sigma_theta^2 / 2, correlated
    with the heading's d sigma_theta^2 / 2). Without it, a 3 m step (orebro's keyframes) was searched within 0.96 m
    and its scan, 1.26 m and 20 deg off the odometry at seed 2, went on odometry alone. The three errors are
    propagated as the particle filter's prior propagates its alphas' (amr_util.geometry.odometry_covariance), the
    position's error added on every side."""
    d = math.hypot(delta[0], delta[1]) if path is None else float(path)
    a = _turned(delta) if turn is None else float(turn)
    s_xy, s_xy_d, s_xy_a, s_th, s_th_a = ODOMETRY_SIGMA
    position = share_xy * (s_xy + s_xy_d * d)
    along = share_xy * s_xy_a * a  # the translation's error with the turns: along the line of travel
    heading = share_theta * (s_th + s_th_a * (a + d))
    direction = math.atan2(delta[1], delta[0])  # no net translation: atan2(0, 0) = 0, x taken as the way on
    covariance = odometry_covariance(direction, d, (0.5 * heading**2, along**2, 0.5 * heading**2))
    covariance[:2, :2] += position**2 * np.eye(2)
    return covariance


def _saved(grid: OccupancyGrid) -> OccupancyGrid:
    """The grid as it is saved: its seen cells below SAVED_FREE_PROBABILITY free (0), the others as they are (the
    trinary format then keeps 65 % and above occupied, the rest unknown)."""
    data = np.where(grid.free(round(100 * SAVED_FREE_PROBABILITY)), FREE, grid.data).astype(np.int8)
    return OccupancyGrid(data, grid.resolution, grid.origin, grid.frame_id)


def _turned(delta) -> float:
    """rad the odometry motion model turns over a motion delta (dx, dy, dtheta; the frame it starts in): its first
    and second rotations, each off the line of travel (amr_util.geometry.odometry_turns, off_line). A turn in place
    that slid a few centimetres sideways turns a quarter turn each way for the model: an odometry that reports it so
    errs as much (the synthesized odometry of a log does; a wheel odometry reports no slide, and then it is the net
    turn)."""
    rot1, _, rot2 = odometry_turns((0.0, 0.0, 0.0), delta)
    return off_line(rot1) + off_line(rot2)


def _match_information(
    matcher: CorrelativeMatcher, points: np.ndarray, pose: np.ndarray, resolution: float
) -> np.ndarray:
    """The information of a match at pose: MATCH_INFORMATION_SCALE times the negative Hessian of the mean
    interpolated score (central differences of the likelihood field's sigma, and the angle that moves the mean
    point that far),
    its eigenvalues clamped at MIN_MATCH_INFORMATION: along a corridor the scan says little, and the
    odometry it is fused with decides there."""
    radius = float(np.mean(np.hypot(points[:, 0], points[:, 1])))
    step = LIKELIHOOD_SIGMA_CELLS * resolution  # the field's own scale: not the bumps between rasterized points
    steps = np.array([step, step, step / max(radius, step)])
    base = np.asarray(pose, dtype=float)

    def score(offset) -> float:
        return matcher.score_interpolated(points, base + offset * steps)

    centre = score(np.zeros(3))
    hessian = np.empty((3, 3))
    unit = np.eye(3)
    for i in range(3):
        hessian[i, i] = score(unit[i]) - 2.0 * centre + score(-unit[i])
        for j in range(i + 1, 3):
            hessian[i, j] = hessian[j, i] = (
                score(unit[i] + unit[j])
                - score(unit[i] - unit[j])
                - score(unit[j] - unit[i])
                + score(-unit[i] - unit[j])
            ) / 4.0
    hessian /= np.outer(steps, steps)
    return _clamped(-MATCH_INFORMATION_SCALE * hessian)


def _clamped(information: np.ndarray) -> np.ndarray:
    """A match's information, symmetric, its eigenvalues at least MIN_MATCH_INFORMATION."""
    values, vectors = np.linalg.eigh(0.5 * (information + information.T))
    values = np.maximum(values, MIN_MATCH_INFORMATION)
    return (vectors * values) @ vectors.T


def _beams(scan: ScanData, max_range_used: float, mount=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ranges, angles, points (K, 2)): the ranges kept for mapping (NaN dropped, +inf no return; in the
    sensor's frame) and the matchable points (finite readings in [range_min, min(range_max, max_range_used)]) in
    the robot's frame (the sensor at `mount` (x, y, yaw) of the robot)."""
    ranges = np.asarray(scan.ranges, dtype=float).reshape(-1)
    if not (is_finite_number(scan.angle_min) and is_finite_number(scan.angle_increment)):
        raise MappingError(
            f"slam: scan angle_min and angle_increment must be finite, got {scan.angle_min!r}, {scan.angle_increment!r}"
        )
    angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
    keep = ~np.isnan(ranges)
    ranges, angles = ranges[keep], angles[keep]
    ranges = np.where(ranges < scan.range_min, -np.inf, ranges)  # REP 117: closer than range_min
    ranges = np.where(ranges > scan.range_max, np.inf, ranges)
    usable = np.isfinite(ranges) & (ranges <= max_range_used)
    heading = angles[usable] + mount[2]
    points = np.column_stack([mount[0] + ranges[usable] * np.cos(heading), mount[1] + ranges[usable] * np.sin(heading)])
    mapped = ranges > 0.0  # -inf (too close) is neither a hit nor a free ray
    return ranges[mapped].astype(np.float32), angles[mapped].astype(np.float32), points


def _insert(grid: LogOddsGrid, poses, nodes, mount=(0.0, 0.0, 0.0)) -> None:
    """The nodes' scans inserted into the log-odds grid at the robot's poses (the sensor at `mount`): a beam without
    a return clears free space up to its node's clear_range (the sensor's range_max, at most max_range_used)."""
    grid.insert_many(
        [compose(pose, mount) for pose in poses],
        [node.ranges for node in nodes],
        [node.angles for node in nodes],
        [node.clear_range for node in nodes],
    )


def save_snapshot(snapshot: SlamSnapshot, config: SlamConfig, path: str | Path) -> list[Path]:
    """A snapshot's map written as GraphSlam.save writes it (<path>.yaml + .pgm, map_server's format, and
    <path>.poses.csv: stamp_ns,x,y,theta per node, map frame), the grid rebuilt at its poses (the map kept in memory
    never shrinks: cells only old poses covered stay unknown); returns the paths. It reads only the snapshot, so a
    node may run it outside the lock it calls GraphSlam.add under (intel's 905 nodes: 0.4 s of build and write
    against 0.1 s of the optimization a save settles first). A file that cannot be written: MappingError naming it."""
    if not snapshot.nodes:
        raise MappingError("slam: no map yet (no scan has been added)")
    grid = _grid_from(snapshot.poses, snapshot.nodes, config, snapshot.mount)
    path = Path(path)
    stem = path.with_suffix("") if path.suffix in (".yaml", ".yml") else path
    csv_path = stem.with_name(stem.name + ".poses.csv")
    try:
        yaml_path = save_map(_saved(grid), stem)
        lines = ["stamp_ns,x,y,theta"] + [
            f"{stamp},{x:.6f},{y:.6f},{theta:.6f}"
            for stamp, (x, y, theta) in zip(snapshot.node_stamps, snapshot.poses, strict=True)
        ]
        csv_path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    except (OSError, MapError) as error:
        raise MappingError(f"slam: cannot save the map to {stem}: {error}") from error
    return [yaml_path, yaml_path.with_suffix(".pgm"), csv_path]


def _grid_from(poses: np.ndarray, nodes, config: SlamConfig, mount=(0.0, 0.0, 0.0)) -> OccupancyGrid:
    """The occupancy grid of the nodes' scans at the poses, built afresh."""
    grid = LogOddsGrid(config.resolution)
    _insert(grid, poses, nodes, mount)
    return grid.to_occupancy_grid()


__all__ = [
    "GraphSlam",
    "KeptMap",
    "LoopClosure",
    "MappingError",
    "SlamConfig",
    "SlamSnapshot",
    "SlamUpdate",
    "save_snapshot",
]
