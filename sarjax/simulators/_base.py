"""Interface shared by all raw-data simulators."""

from __future__ import annotations

import abc

import equinox as eqx


class AbstractSimulator(eqx.Module):
    """A raw-data simulator: ``simulator(radar, scene, motion, acquisition, dtype)``.

    Returns the (azimuth, range) complex raw data on ``acquisition``'s grid. Options are
    module fields; :func:`sarjax.simulate` is the one jitted entry point.
    """

    @abc.abstractmethod
    def __call__(self, radar, scene, motion, acquisition, dtype):
        """Simulate raw data; see :func:`sarjax.simulate`."""

    def prepare(self, radar, scene, acquisition):
        """Eager (outside ``jit``) checks and static sizes from concrete values; returns the
        simulator to run (default: unchanged)."""
        return self
