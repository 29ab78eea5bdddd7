"""The base of the plant wrappers (faults, collision watches): the Plant role read through, explicitly.

A wrapper changes one part of the plant it wraps (:class:`agvnav.sim.faults.FaultyPlant` its
odometry, :class:`agvnav.sim.collision.CollisionWatch` and
:class:`agvnav.sim.reactive.ObstacleCollisionWatch` its failure). :class:`WrappedPlant` gives it the
rest of :class:`agvnav.roles.Plant`: ``pose_at`` and ``signals`` as the plant's own bound methods
(no per-step indirection), ``signal_names``, and ``family``, ``geometry``, ``footprint`` and
``pose`` as read-only properties. Each wrapper defines (or binds) ``advance``, ``odometry`` and
``failure`` itself. Nothing else is forwarded: a reader of another attribute names the plant.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvnav.roles import Plant

__all__ = ["WrappedPlant"]


class WrappedPlant:
    """The Plant role of ``plant`` read through (module doc); ``plant`` is the wrapped plant."""

    def __init__(self, plant: Plant) -> None:
        self.plant = plant
        self.pose_at = plant.pose_at
        self.signals = plant.signals
        self.signal_names = plant.signal_names

    @property
    def family(self) -> str:
        """The wrapped plant's family."""
        return self.plant.family

    @property
    def geometry(self) -> object:
        """The wrapped plant's nominal geometry."""
        return self.plant.geometry

    @property
    def footprint(self) -> NDArray[np.float64]:
        """The wrapped plant's body polygon ``(k, 2)`` in base_link (m)."""
        return self.plant.footprint

    @property
    def pose(self) -> NDArray[np.float64]:
        """The wrapped plant's true pose ``(3,)`` (m, m, rad)."""
        return self.plant.pose
