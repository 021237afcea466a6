"""Spread start configurations for restarts: Latin-hypercube batches inside the limits.

Independent uniform draws cluster and leave holes; a Latin hypercube of N points
cuts every joint's range in N strata and puts one point in each (strata paired
at random between joints), so N starts cover every joint's range evenly.
Restarting solvers take their starts from successive hypercubes: consecutive
starts are random subsets of one hypercube, and all of them together are spread.
"""

from __future__ import annotations

import threading
import weakref

import numpy as np


def latin_hypercube(rng: np.random.Generator, lower: np.ndarray, upper: np.ndarray, samples: int) -> np.ndarray:
    """(samples, dims) points: every dimension has one point in each of its strata."""
    dims = lower.size
    strata = rng.permuted(np.tile(np.arange(samples), (dims, 1)), axis=1)
    unit = (strata + rng.random((dims, samples))) / samples
    return (lower[:, None] + (upper - lower)[:, None] * unit).T


class SpreadStarts:
    """Full joint vectors drawn from successive hypercubes over the independent joints
    (coupled joints derived from them).  ``take`` reads the sequence of hypercubes that the
    chain, batch size and seed define (``_Hypercubes``), drawn once per process and shared by the
    solves: drawing one cost 30-60 us, as much as a restart's descent."""

    def __init__(self, chain, template: np.ndarray, batch: int, random_seed: int) -> None:
        self.chain = chain
        self.template = template
        self.batch = max(1, batch)
        self.random_seed = random_seed
        self.rng = None
        self.sequence: _Hypercubes | None = None
        self.cube = -1
        self.pending: np.ndarray | None = None
        self.next = 0

    def take(self, count: int) -> np.ndarray:
        """The next ``count`` starts, (count, n)."""
        out = []
        while count > 0:
            if self.pending is None or self.next == len(self.pending):
                if self.sequence is None:
                    self.sequence = _Hypercubes.of(self.chain, self.batch, self.random_seed)
                self.cube += 1
                if self.cube < _Hypercubes.CACHED:
                    self.pending = self.sequence.cube(self.cube)
                else:  # past the shared ones: on with the sequence's generator, privately
                    if self.cube == _Hypercubes.CACHED:
                        self.rng = np.random.default_rng()
                        self.rng.bit_generator.state = self.sequence.state_after()
                    self.pending = _draw(self.chain, self.template, self.rng, self.batch)
                self.next = 0
            used = self.pending[self.next : self.next + count]
            self.next += len(used)
            count -= len(used)
            out.append(used)
        return out[0].copy() if len(out) == 1 else np.vstack(out)  # copies: the shared cubes are read-only

    def draw(self, samples: int) -> np.ndarray:
        """One new hypercube of ``samples`` starts, (samples, n), from this object's generator
        (made at the first draw: creating one costs ~10 us)."""
        if self.rng is None:
            self.rng = np.random.default_rng(self.random_seed)
        return _draw(self.chain, self.template, self.rng, samples)


def _draw(chain, template: np.ndarray, rng: np.random.Generator, samples: int) -> np.ndarray:
    free = chain.free
    starts = np.tile(template, (samples, 1))
    starts[:, free] = latin_hypercube(rng, chain.lower[free], chain.upper[free], samples)
    if chain.couplings:
        starts = np.array([chain.apply_coupling(q) for q in starts])
    return starts


class _Hypercubes:
    """The hypercubes ``default_rng(seed)`` draws one after the other for a chain: the first
    ``CACHED`` are kept (read-only) and shared; a solve that needs more continues from the
    generator's state after them, on its own.  Every joint is free or coupled, so the starts
    do not depend on a solve's seed configuration."""

    CACHED = 16
    _by_chain: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
    _lock = threading.Lock()

    @classmethod
    def of(cls, chain, batch: int, random_seed: int) -> _Hypercubes:
        with cls._lock:
            shared = cls._by_chain.setdefault(chain, {})
            sequence = shared.get((batch, random_seed))
            if sequence is None:
                sequence = cls(chain, batch, random_seed)
                if len(shared) < 16:  # a bound on memory if many seeds are asked for
                    shared[(batch, random_seed)] = sequence
            return sequence

    def __init__(self, chain, batch: int, random_seed: int) -> None:
        self.chain = chain
        self.batch = batch
        self.rng = np.random.default_rng(random_seed)
        self.cubes: list[np.ndarray] = []
        self.lock = threading.Lock()
        self.zeros = np.zeros(chain.n)

    def cube(self, index: int) -> np.ndarray:
        """Hypercube number ``index`` (< CACHED) of the sequence."""
        if index < len(self.cubes):
            return self.cubes[index]
        with self.lock:
            while len(self.cubes) <= index:
                cube = _draw(self.chain, self.zeros, self.rng, self.batch)
                cube.flags.writeable = False
                self.cubes.append(cube)
        return self.cubes[index]

    def state_after(self) -> dict:
        """The generator's state after the CACHED hypercubes."""
        self.cube(self.CACHED - 1)
        return self.rng.bit_generator.state
