"""A Pose2 pose graph and its sparse Levenberg-Marquardt optimizer (scipy), no ROS.

Nodes are robot poses (x, y, theta) in the map frame; an edge (i, j) is a measured motion z = (dx, dy, dtheta)
of node j seen from node i (odometry, a scan match, a loop closure) with a 3x3 information matrix (the
inverse of its covariance). The error of an edge is the one of Grisetti et al., "A tutorial on graph-based
SLAM" (2010):

    e_t = R_z^T (R_i^T (t_j - t_i) - t_z),   e_theta = wrap(theta_j - theta_i - theta_z)

and the optimizer minimizes sum rho(e^T Omega e) over the edges, node 0 held fixed (the gauge). rho is the
identity for odometry and scan-match edges (or a Cauchy kernel of a fixed width: edge_kernel_width) and a
robust kernel (Cauchy by default, or Huber) for loop closures, applied by iteratively reweighted least squares:
a closure whose error is many standard deviations off weighs c^2 / (c^2 + s) of itself, so one false closure
bends the map little instead of wrecking it. Each iteration builds the sparse normal equations H dx = -b in one
pass of numpy over all edges and solves them with SuperLU (scipy.sparse.linalg.splu); LM damping
(H + lambda diag H) makes a step that raises the cost be retried smaller.

An optimization that diverges (a non-finite cost or step, a singular system) or stalls (no damping finds a
step that lowers the cost while the gradient is not yet small) raises MappingError and leaves the poses as
they were. docs/amr_mapping.md has the measurement against gtsam 4.3.0 that chose this optimizer.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from amr_mapping.errors import MappingError
from amr_util.geometry import wrap_angle

KERNELS = ("cauchy", "huber", "none")


@dataclass(frozen=True)
class OptimizeResult:
    """What one optimize() call did: iterations, the robust cost before and after, whether it converged
    (False when the iteration budget ran out while still improving: the improved poses are kept), the
    largest pose change (m, rad) and the wall time (s)."""

    iterations: int
    initial_cost: float
    final_cost: float
    converged: bool
    max_change: float
    seconds: float


class Marginals:
    """A factored pose-graph information (PoseGraph.marginals): joint covariances of nodes on request."""

    def __init__(self, factor, count: int) -> None:
        self._factor = factor
        self._count = count

    def covariance(self, indices) -> np.ndarray:
        """(3k, 3k) joint covariance of nodes `indices`, in that order; node 0 (fixed) has zero rows."""
        indices = np.asarray(indices, dtype=np.int64).reshape(-1)
        if len(indices) == 0 or indices.min() < 0 or indices.max() >= self._count:
            raise MappingError(f"pose graph: marginal covariance: indices must be in 0..{self._count - 1}")
        k = len(indices)
        covariance = np.zeros((3 * k, 3 * k))
        if self._factor is None:
            return covariance
        columns = (3 * indices[:, None] + np.arange(3)).ravel()
        free = np.flatnonzero(columns >= 3)
        if len(free) == 0:
            return covariance
        unit = np.zeros((3 * (self._count - 1), len(free)))
        unit[columns[free] - 3, np.arange(len(free))] = 1.0
        solved = self._factor.solve(unit)
        covariance[np.ix_(free, free)] = solved[columns[free] - 3]
        return 0.5 * (covariance + covariance.T)


class Optimization:
    """One Levenberg-Marquardt run over a PoseGraph, iterations taken a few at a time (step), so that an online
    caller can bound the time an update spends on it and carry the rest over to the next updates.

    The loop-closure kernel is graduated (as graduated non-convexity, Yang et al. 2020): its width starts wide
    enough that every closure weighs at least half (a true closure found after a long drift is many standard
    deviations off at first) and halves each iteration down to kernel_width, so the closures that agree with each
    other and the odometry pull the graph before the odd one out is turned down. The run is done at kernel_width
    when the relative cost decrease or the largest step falls below `tolerance`, or after max_iterations. Each
    iteration takes the graph as it is then (nodes and edges added since the last step included; a new node starts
    where it was put); the width and the damping carry over. MappingError (divergence, a stall) keeps the poses of
    the last accepted iteration."""

    def __init__(self, graph: PoseGraph, max_iterations: int, tolerance: float, first_free: int) -> None:
        self._graph = graph
        self.max_iterations = int(max_iterations)
        self.tolerance = float(tolerance)
        self.first_free = max(1, int(first_free))
        self.iterations = 0
        self.solves = 0
        """linear solves so far (one per damping tried): what an iteration costs, about 8 us per edge here."""
        self.converged = False
        self.seconds = 0.0
        n, m = graph.node_count, graph.edge_count
        self._start = graph.poses
        self.initial_cost = graph.cost() if m else 0.0
        self._empty = n <= self.first_free or m == 0
        if not self._empty and not math.isfinite(self.initial_cost):
            raise MappingError(
                f"pose graph: the cost at the initial poses is not finite ({self.initial_cost}); poses kept"
            )
        loop = graph.loop
        self._width = graph.kernel_width
        if graph.loop_kernel != "none" and loop.any():
            self._width = max(self._width, float(np.sqrt(graph.chi2()[loop].max())))
        self._lam = 1e-4

    @property
    def done(self) -> bool:
        """Converged, its iterations spent, or nothing to optimize."""
        return self._empty or self.converged or self.iterations >= self.max_iterations

    def step(self, iterations: int = 1) -> bool:
        """Up to `iterations` more iterations (fewer when done first); returns done."""
        start = time.perf_counter()
        try:
            for _ in range(iterations):
                if self.done:
                    break
                self._iterate()
        finally:
            self.seconds += time.perf_counter() - start
        return self.done

    def result(self) -> OptimizeResult:
        """The run so far: iterations, the robust cost at its start and now, converged, the largest change of a pose
        it started with (m, rad), seconds spent in step."""
        graph = self._graph
        n = len(self._start)
        poses = graph.poses[:n]
        change = np.abs(poses - self._start)
        change[:, 2] = np.abs(wrap_angle(poses[:, 2] - self._start[:, 2]))
        converged = self.converged or (self._empty and self.iterations == 0)
        return OptimizeResult(
            self.iterations,
            self.initial_cost,
            graph.cost() if graph.edge_count else 0.0,
            converged,
            float(change.max(initial=0.0)),
            self.seconds,
        )

    def _iterate(self) -> None:
        graph = self._graph
        n, m = graph._count, graph._edges
        first_free = self.first_free
        tolerance = self.tolerance
        ij, z, info = graph._ij[:m], graph._z[:m], graph._info[:m]
        poses = graph._poses[:n].copy()
        width = self._width
        self.iterations += 1
        e = _errors(poses, ij, z)
        s = np.einsum("mi,mij,mj->m", e, info, e)
        rho, weight = graph._kernel(s, width)
        cost = 0.5 * float(rho.sum())
        final = width <= graph.kernel_width
        a, b = _jacobians(poses, ij, z)
        hessian, gradient = _normal_equations(n, ij, a, b, info * weight[:, None, None], e)
        free = slice(3 * first_free, 3 * n)
        h = hessian[free, free].tocsc()
        g = gradient[free]
        if np.abs(g).max() < 1e-10 and final:
            self.converged = True
            return
        diag = h.diagonal()
        accepted = False
        lam = self._lam
        while lam < 1e12:
            damped = h + sp.diags(lam * np.maximum(diag, 1e-9), format="csc")
            self.solves += 1
            try:
                step = splu(damped, permc_spec="COLAMD").solve(-g)  # the fastest of SuperLU's orders here
            except RuntimeError as error:  # exactly singular
                raise MappingError(f"pose graph: singular normal equations ({error}); poses kept") from error
            if not np.all(np.isfinite(step)):
                raise MappingError("pose graph: the optimization diverged (a non-finite step); poses kept")
            trial = poses.copy()
            trial[first_free:] += step.reshape(-1, 3)
            trial[:, 2] = wrap_angle(trial[:, 2])
            new_cost = 0.5 * float(graph._kernel(graph.chi2(trial), width)[0].sum())
            if not math.isfinite(new_cost):
                raise MappingError("pose graph: the optimization diverged (a non-finite cost); poses kept")
            small = np.abs(step).max() < tolerance
            if new_cost <= cost:
                accepted = True
                poses = trial
                lam = max(lam / 10.0, 1e-9)
                self.converged = final and (cost - new_cost <= tolerance * max(new_cost, 1e-12) or small)
                break
            if abs(cost - new_cost) <= tolerance * max(cost, 1e-12) and np.abs(step).max() < 1e3 * tolerance:
                accepted = True  # at the minimum: rounding makes any step cost a hair more
                self.converged = final
                break
            lam *= 10.0
        self._lam = lam
        if not accepted:
            raise MappingError(
                f"pose graph: the optimization stalled (no step lowers the cost {cost:.6g}, "
                f"gradient {np.abs(g).max():.3g}); poses kept"
            )
        graph._poses[:n] = poses
        if not self.converged:
            self._width = max(graph.kernel_width, 0.5 * width)


class PoseGraph:
    """Nodes (x, y, theta) and edges with information matrices; `optimize` moves the nodes (node 0 fixed)."""

    def __init__(
        self, loop_kernel: str = "cauchy", kernel_width: float = 3.0, edge_kernel_width: float | None = None
    ) -> None:
        """loop_kernel: 'cauchy', 'huber' or 'none' for loop-closure edges; kernel_width: c, in standard
        deviations (the square root of e^T Omega e) at which the kernel starts to down-weight (1-10);
        edge_kernel_width: a Cauchy kernel of this width on the other edges (odometry, scan matches; graduated
        as the closures' kernel is, down to it), None: plain least squares. A chain without closures is unchanged
        by it (its edges are met exactly); with closures, one scan match far off (a wrong heading mode in a fast
        turn) gives way to the closures and its neighbours instead of bending them."""
        if loop_kernel not in KERNELS:
            raise MappingError(f"pose graph: loop_kernel must be one of {', '.join(KERNELS)}, got {loop_kernel!r}")
        if not (math.isfinite(kernel_width) and kernel_width > 0.0):
            raise MappingError(f"pose graph: kernel_width must be a positive number, got {kernel_width!r}")
        if edge_kernel_width is not None and not (
            isinstance(edge_kernel_width, (int, float)) and math.isfinite(edge_kernel_width) and edge_kernel_width > 0
        ):
            raise MappingError(
                f"pose graph: edge_kernel_width must be a positive number or None, got {edge_kernel_width!r}"
            )
        self.loop_kernel = loop_kernel
        self.kernel_width = float(kernel_width)
        self.edge_kernel_width = None if edge_kernel_width is None else float(edge_kernel_width)
        self._poses = np.zeros((0, 3))
        self._count = 0
        self._ij = np.zeros((0, 2), dtype=np.int64)
        self._z = np.zeros((0, 3))
        self._info = np.zeros((0, 3, 3))
        self._loop = np.zeros(0, dtype=bool)
        self._edges = 0

    # -- building ----------------------------------------------------------------------------------

    @property
    def node_count(self) -> int:
        return self._count

    @property
    def edge_count(self) -> int:
        return self._edges

    @property
    def poses(self) -> np.ndarray:
        """(N, 3) node poses (a copy)."""
        return self._poses[: self._count].copy()

    def pose(self, index: int) -> np.ndarray:
        return self._poses[index].copy()

    @property
    def edges(self) -> np.ndarray:
        """(M, 2) int node pairs (i, j)."""
        return self._ij[: self._edges].copy()

    @property
    def measurements(self) -> np.ndarray:
        """(M, 3) the edges' measured motions (dx, dy, dtheta of node j in node i's frame; a copy)."""
        return self._z[: self._edges].copy()

    @property
    def information(self) -> np.ndarray:
        """(M, 3, 3) the edges' information matrices (a copy)."""
        return self._info[: self._edges].copy()

    @property
    def loop(self) -> np.ndarray:
        """(M,) bool: which edges are loop closures."""
        return self._loop[: self._edges].copy()

    def add_node(self, pose) -> int:
        """Adds a node at `pose` (x, y, theta); returns its index."""
        pose = np.asarray(pose, dtype=float)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise MappingError(f"pose graph: a node pose must be 3 finite numbers (x, y, theta), got {pose!r}")
        if self._count == len(self._poses):
            self._poses = np.vstack([self._poses, np.zeros((max(64, self._count), 3))])
        self._poses[self._count] = (pose[0], pose[1], wrap_angle(float(pose[2])))
        self._count += 1
        return self._count - 1

    def add_edge(self, i: int, j: int, measurement, information, loop: bool = False) -> int:
        """Adds the measured motion (dx, dy, dtheta) of node j in node i's frame with its 3x3 information
        matrix (symmetric positive definite); loop marks a loop closure (robust kernel). Returns its index."""
        if not (0 <= i < self._count and 0 <= j < self._count) or i == j:
            raise MappingError(f"pose graph: edge ({i}, {j}) must join two different nodes of 0..{self._count - 1}")
        z = np.asarray(measurement, dtype=float)
        info = np.asarray(information, dtype=float)
        if z.shape != (3,) or not np.all(np.isfinite(z)):
            raise MappingError(f"pose graph: edge ({i}, {j}): measurement must be 3 finite numbers, got {z!r}")
        if (
            info.shape != (3, 3)
            or not np.isfinite(info).all()
            or np.abs(info - info.T).max() > 1e-9 * (1.0 + np.abs(info).max())
        ):
            raise MappingError(f"pose graph: edge ({i}, {j}): information must be a finite symmetric 3x3 matrix")
        try:
            np.linalg.cholesky(info)
        except np.linalg.LinAlgError:
            raise MappingError(f"pose graph: edge ({i}, {j}): information must be positive definite") from None
        if self._edges == len(self._ij):
            grow = max(64, self._edges)
            self._ij = np.vstack([self._ij, np.zeros((grow, 2), dtype=np.int64)])
            self._z = np.vstack([self._z, np.zeros((grow, 3))])
            self._info = np.concatenate([self._info, np.zeros((grow, 3, 3))])
            self._loop = np.concatenate([self._loop, np.zeros(grow, dtype=bool)])
        k = self._edges
        self._ij[k] = (i, j)
        self._z[k] = (z[0], z[1], wrap_angle(float(z[2])))
        self._info[k] = 0.5 * (info + info.T)
        self._loop[k] = bool(loop)
        self._edges += 1
        return k

    def remove_edges(self, indices) -> None:
        """Removes the edges of the given indices (a closure found inconsistent); the others keep their order."""
        drop = np.zeros(self._edges, dtype=bool)
        indices = np.asarray(indices, dtype=np.int64).reshape(-1)
        if len(indices) and (indices.min() < 0 or indices.max() >= self._edges):
            raise MappingError(f"pose graph: remove_edges: indices must be in 0..{self._edges - 1}, got {indices!r}")
        drop[indices] = True
        keep = np.flatnonzero(~drop)
        m = len(keep)
        self._ij[:m], self._z[:m], self._info[:m], self._loop[:m] = (
            self._ij[keep],
            self._z[keep],
            self._info[keep],
            self._loop[keep],
        )
        self._edges = m

    def set_poses(self, poses) -> None:
        """Replaces every node pose (an (N, 3) array of the graph's N nodes)."""
        poses = np.asarray(poses, dtype=float)
        if poses.shape != (self._count, 3) or not np.all(np.isfinite(poses)):
            raise MappingError(f"pose graph: set_poses needs ({self._count}, 3) finite poses, got {poses.shape}")
        self._poses[: self._count] = poses
        self._poses[: self._count, 2] = wrap_angle(poses[:, 2])

    def move_after(self, index: int, correction) -> None:
        """Composes the rigid correction (x, y, theta), a map-frame transform, onto nodes index.. (the
        nodes not yet optimized follow the ones that were)."""
        x, y, theta = correction
        c, s = math.cos(theta), math.sin(theta)
        p = self._poses[index : self._count]
        px, py = p[:, 0].copy(), p[:, 1].copy()
        p[:, 0] = c * px - s * py + x
        p[:, 1] = s * px + c * py + y
        p[:, 2] = wrap_angle(p[:, 2] + theta)

    # -- optimizing --------------------------------------------------------------------------------

    def errors(self, poses: np.ndarray | None = None) -> np.ndarray:
        """(M, 3) edge errors at `poses` (the current ones by default)."""
        poses = self._poses[: self._count] if poses is None else poses
        return _errors(poses, self._ij[: self._edges], self._z[: self._edges])

    def chi2(self, poses: np.ndarray | None = None) -> np.ndarray:
        """(M,) e^T Omega e per edge."""
        e = self.errors(poses)
        return np.einsum("mi,mij,mj->m", e, self._info[: self._edges], e)

    def cost(self, poses: np.ndarray | None = None) -> float:
        """The robust cost sum rho(e^T Omega e) / 2 at `poses`."""
        rho, _ = self._kernel(self.chi2(poses))
        return 0.5 * float(rho.sum())

    def optimize(self, max_iterations: int = 30, tolerance: float = 1e-6, first_free: int = 1) -> OptimizeResult:
        """Levenberg-Marquardt over nodes first_free.. (the ones before held fixed; node 0 at least): an
        Optimization run to its end (converged, or max_iterations spent). See Optimization. Raises MappingError,
        keeping the poses, on divergence or a stall (see the module docstring)."""
        run = self.optimization(max_iterations, tolerance, first_free)
        run.step(max_iterations)
        return run.result()

    def optimization(self, max_iterations: int = 30, tolerance: float = 1e-6, first_free: int = 1) -> Optimization:
        """A Levenberg-Marquardt run that can be carried out a few iterations at a time (Optimization.step): between
        two steps nodes and edges may be added (each iteration takes the graph as it is then), and the poses stay the
        last accepted step's, which lowered the cost: a consistent graph at every step."""
        return Optimization(self, max_iterations, tolerance, first_free)

    def marginals(self, information: np.ndarray | None = None) -> Marginals:
        """The graph's own uncertainty at the current poses: the inverse of its information (J^T Omega J over
        every edge, loop closures weighted by the robust kernel at kernel_width; node 0 fixed), factored once;
        `Marginals.covariance(indices)` reads the joint covariance of any nodes from it (a loop closure shortens
        the chain between two nodes). information: (M, 3, 3) per-edge informations to use instead of the
        edges' own (as a gate may count the scan matches differently from the optimizer)."""
        n, m = self._count, self._edges
        if n < 2 or m == 0:
            return Marginals(None, n)
        ij, z = self._ij[:m], self._z[:m]
        info = self._info[:m] if information is None else np.asarray(information, dtype=float)
        if info.shape != (m, 3, 3) or not np.all(np.isfinite(info)):
            raise MappingError(f"pose graph: marginals: information must be ({m}, 3, 3) finite, got {info.shape}")
        poses = self._poses[:n]
        e = _errors(poses, ij, z)
        _, weight = self._kernel(np.einsum("mi,mij,mj->m", e, self._info[:m], e))
        a, b = _jacobians(poses, ij, z)
        hessian, _ = _normal_equations(n, ij, a, b, info * weight[:, None, None], e)
        h = hessian[3:, 3:].tocsc()
        h = h + sp.diags(np.full(h.shape[0], 1e-12 * max(float(np.abs(h.diagonal()).max()), 1.0)), format="csc")
        try:
            return Marginals(splu(h, permc_spec="COLAMD"), n)
        except RuntimeError as error:
            raise MappingError(f"pose graph: marginals: singular information ({error})") from error

    def marginal_covariance(self, indices) -> np.ndarray:
        """The joint covariance (3k, 3k) of nodes `indices` (see marginals; node 0's rows and columns zero)."""
        return self.marginals().covariance(indices)

    def _kernel(self, s: np.ndarray, width: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(rho(s), rho'(s)) per edge: s for odometry edges (Cauchy's of edge_kernel_width if set, widened as the
        closures' is), the robust kernel's (of width c, kernel_width by default) for loop closures."""
        rho = s.copy()
        weight = np.ones_like(s)
        loop = self._loop[: self._edges]
        if self.edge_kernel_width is not None:
            # graduated with the closures' kernel (its width over kernel_width): both start near least squares, so
            # a false closure is not met by breaking the scan matches at its ends
            e2 = (
                self.edge_kernel_width * max(1.0, (self.kernel_width if width is None else width) / self.kernel_width)
            ) ** 2
            rho[~loop] = e2 * np.log1p(s[~loop] / e2)
            weight[~loop] = 1.0 / (1.0 + s[~loop] / e2)
        if self.loop_kernel == "none" or not loop.any():
            return rho, weight
        c = self.kernel_width if width is None else width
        c2 = c * c
        sl = s[loop]
        if self.loop_kernel == "cauchy":
            rho[loop] = c2 * np.log1p(sl / c2)
            weight[loop] = 1.0 / (1.0 + sl / c2)
        else:  # huber on the residual's norm r = sqrt(s): r^2 inside c, 2 c r - c^2 outside
            r = np.sqrt(sl)
            outside = r > c
            rho[loop] = np.where(outside, 2.0 * c * r - c2, sl)
            weight[loop] = np.where(outside, c / np.maximum(r, 1e-300), 1.0)
        return rho, weight


def _errors(poses: np.ndarray, ij: np.ndarray, z: np.ndarray) -> np.ndarray:
    pi, pj = poses[ij[:, 0]], poses[ij[:, 1]]
    ci, si = np.cos(pi[:, 2]), np.sin(pi[:, 2])
    dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
    lx = ci * dx + si * dy - z[:, 0]
    ly = -si * dx + ci * dy - z[:, 1]
    cz, sz = np.cos(z[:, 2]), np.sin(z[:, 2])
    return np.column_stack([cz * lx + sz * ly, -sz * lx + cz * ly, wrap_angle(pj[:, 2] - pi[:, 2] - z[:, 2])])


def _jacobians(poses: np.ndarray, ij: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M, 3, 3) de/dx_i and de/dx_j."""
    pi, pj = poses[ij[:, 0]], poses[ij[:, 1]]
    ci, si = np.cos(pi[:, 2]), np.sin(pi[:, 2])
    cz, sz = np.cos(z[:, 2]), np.sin(z[:, 2])
    dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
    # R = R_z^T R_i^T, written out
    r00 = cz * ci - sz * si
    r01 = cz * si + sz * ci
    r10 = -(sz * ci + cz * si)
    r11 = cz * ci - sz * si
    # d(R_i^T)/dtheta_i (t_j - t_i) = (-si dx + ci dy, -ci dx - si dy), then rotated by R_z^T
    ux, uy = -si * dx + ci * dy, -ci * dx - si * dy
    m = len(ij)
    a = np.zeros((m, 3, 3))
    b = np.zeros((m, 3, 3))
    a[:, 0, 0], a[:, 0, 1], a[:, 1, 0], a[:, 1, 1] = -r00, -r01, -r10, -r11
    a[:, 0, 2] = cz * ux + sz * uy
    a[:, 1, 2] = -sz * ux + cz * uy
    a[:, 2, 2] = -1.0
    b[:, 0, 0], b[:, 0, 1], b[:, 1, 0], b[:, 1, 1] = r00, r01, r10, r11
    b[:, 2, 2] = 1.0
    return a, b


_BLOCK_ROWS, _BLOCK_COLS = np.divmod(np.arange(9), 3)


def _normal_equations(
    n: int, ij: np.ndarray, a: np.ndarray, b: np.ndarray, info: np.ndarray, e: np.ndarray
) -> tuple[sp.csr_matrix, np.ndarray]:
    """H = sum J^T Omega J and g = sum J^T Omega e over the edges, as a (3n, 3n) sparse matrix and a vector."""
    at_o = np.einsum("mki,mkl->mil", a, info)  # A^T Omega
    bt_o = np.einsum("mki,mkl->mil", b, info)
    blocks = (
        (ij[:, 0], ij[:, 0], np.einsum("mil,mlj->mij", at_o, a)),
        (ij[:, 0], ij[:, 1], np.einsum("mil,mlj->mij", at_o, b)),
        (ij[:, 1], ij[:, 0], np.einsum("mil,mlj->mij", bt_o, a)),
        (ij[:, 1], ij[:, 1], np.einsum("mil,mlj->mij", bt_o, b)),
    )
    rows = np.concatenate([(3 * r[:, None] + _BLOCK_ROWS).ravel() for r, _, _ in blocks])
    cols = np.concatenate([(3 * c[:, None] + _BLOCK_COLS).ravel() for _, c, _ in blocks])
    vals = np.concatenate([v.reshape(-1) for _, _, v in blocks])
    hessian = sp.csr_matrix((vals, (rows, cols)), shape=(3 * n, 3 * n))
    gradient = np.zeros(3 * n)
    np.add.at(gradient, (3 * ij[:, 0][:, None] + np.arange(3)).ravel(), np.einsum("mij,mj->mi", at_o, e).ravel())
    np.add.at(gradient, (3 * ij[:, 1][:, None] + np.arange(3)).ravel(), np.einsum("mij,mj->mi", bt_o, e).ravel())
    return hessian, gradient
