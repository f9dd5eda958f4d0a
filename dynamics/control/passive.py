"""The passive joint torques the simulator always adds (the laws are in :mod:`dynamics.torques`' docstring):
viscous damping, regularised Coulomb friction and, with ``limits="spring"``, a Hunt-Crossley spring-damper at
the position limits; the core evaluates them (``core/control/passive.cpp``)."""

from typing import NamedTuple

import numpy as np


class Passive(NamedTuple):
    """Model and simulation parameters of the passive joint torques (the core's: ``core/control/passive.hpp``)."""

    damping: np.ndarray  # (nv,)
    friction: np.ndarray  # (nv,)
    friction_eps: float
    limits: int  # 0 none, 1 spring
    lower: np.ndarray  # (nv,)
    upper: np.ndarray  # (nv,)
    qpos: np.ndarray  # (nv,) int64: q index of a 1-dof coordinate, -1 for free-joint coordinates
    k_limit: float
    b_limit: float
    gravity: np.ndarray  # (3,)
    f_ext: np.ndarray  # (0, 6)


