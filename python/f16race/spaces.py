"""Observation and action spaces after Gymnasium's `spaces.Box` and `spaces.Dict`, by convention.

Gymnasium is not a Debian package, so f16race does not depend on it: these small classes carry the
same attributes (shape, dtype, low, high, sample(), contains()) that RL code reads from a Box, and
a Dict space is a plain dict of them. With Gymnasium installed, `gymnasium.spaces.Box(b.low,
b.high, dtype=b.dtype)` converts one.
"""
import numpy as np


class Box:
    """A bounded array space: values of `shape` and `dtype` in [low, high] elementwise."""

    def __init__(self, low, high, shape, dtype):
        self.shape = tuple(int(n) for n in shape)
        self.dtype = np.dtype(dtype)
        self.low = np.broadcast_to(np.asarray(low, dtype=self.dtype), self.shape)
        self.high = np.broadcast_to(np.asarray(high, dtype=self.dtype), self.shape)

    def sample(self, rng=None):
        """A uniform draw (integers: in [low, high]); rng: a numpy Generator."""
        rng = np.random.default_rng() if rng is None else rng
        if self.dtype == np.bool_:
            return rng.integers(0, 2, size=self.shape).astype(np.bool_)
        if np.issubdtype(self.dtype, np.integer):
            return rng.integers(self.low, self.high, endpoint=True, size=self.shape).astype(self.dtype)
        low = np.maximum(self.low, np.finfo(self.dtype).min / 2)
        high = np.minimum(self.high, np.finfo(self.dtype).max / 2)
        return rng.uniform(low, high, size=self.shape).astype(self.dtype)

    def contains(self, x):
        x = np.asarray(x)
        return x.shape == self.shape and x.dtype == self.dtype and bool(np.all(x >= self.low) and np.all(x <= self.high))

    __contains__ = contains

    def __repr__(self):
        return f"Box({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype})"


def observation_boxes(shapes, batch=()):
    """{name: Box} for observation shapes {name: (n_agent, ...)}; `batch` is prepended to each."""
    out = {}
    for name, shape in shapes.items():
        shape = tuple(batch) + tuple(shape)
        if name == "ado_alive":
            out[name] = Box(False, True, shape, np.bool_)
        else:
            out[name] = Box(-np.inf, np.inf, shape, np.float32)
    return out
