"""Each body's inertia checked as a rigid body's must be, and the uniform box that has it.

A rotational inertia about the centre of mass, I_c = integral of (|r|^2 1 - r r^T) dm, is positive semidefinite,
and its principal moments I1 <= I2 <= I3 obey the triangle inequality I3 <= I1 + I2: about the principal axes,
I1 + I2 - I3 = 2 integral of z^2 dm >= 0 (z along the third axis). ``dynamics.load_urdf`` applies the same rule
to every URDF link as it reads it (a relative violation above ``INERTIA_WARN`` is a warning, above
``INERTIA_REFUSE`` a refusal); :func:`check_inertias` applies it to the bodies of the model as built (the links
merged through fixed joints added together), which is what the dynamics use and ``dynamics check`` reports on.

The inertia box: a uniform box of mass m and edges (a, b, c) along the principal axes has moments
m (b^2 + c^2) / 12, m (a^2 + c^2) / 12, m (a^2 + b^2) / 12, so a = sqrt(6 (I2 + I3 - I1) / m) and so on: the box a
viewer draws for a body without collision geometry (each edge 0 where the triangle inequality fails).
All quantities in the body frame (the frame of the joint that moves the body).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .checks import check_model
from .urdf import INERTIA_ABS_TOL, INERTIA_REFUSE, INERTIA_WARN


class InertiaCheck(NamedTuple):
    """One body's mass properties and their check (body frame; kg, m, kg m^2)."""
    body: str
    mass: float
    com: np.ndarray                #: (3,) centre of mass
    inertia: np.ndarray            #: (3, 3) rotational inertia about the centre of mass
    principal_moments: np.ndarray  #: (3,) ascending
    principal_axes: np.ndarray     #: (3, 3) columns: the principal axes, a right-handed rotation
    positive_definite: bool        #: smallest principal moment > 0 (a massless body: False)
    triangle: bool                 #: I3 <= I1 + I2 within round-off
    relative_violation: float      #: max(-I1, I3 - I1 - I2, 0) / trace: what load_urdf compares with its thresholds
    box: np.ndarray                #: (3,) edges of the uniform box of this mass and inertia, along principal_axes

    @property
    def verdict(self) -> str:
        """'ok', 'warning' (a violation load_urdf accepts with a warning) or 'refused' (one it refuses unless
        strict_inertia=False)."""
        if self.relative_violation <= INERTIA_WARN:
            return "ok"
        return "refused" if self.relative_violation > INERTIA_REFUSE else "warning"


def _check(name: str, mass: float, com: np.ndarray, inertia: np.ndarray) -> InertiaCheck:
    I = 0.5 * (inertia + inertia.T)
    moments, axes = np.linalg.eigh(I)
    if np.linalg.det(axes) < 0:  # a rotation, so that a viewer can use it as one
        axes[:, 2] = -axes[:, 2]
    negative = max(0.0, -moments[0])
    excess = max(0.0, moments[2] - moments[0] - moments[1])
    bad = max(negative, excess)
    relative = bad / max(abs(float(np.trace(I))), 1e-300) if bad > INERTIA_ABS_TOL else 0.0
    box = np.zeros(3)
    if mass > 0:
        total = moments.sum()
        box = np.sqrt(np.maximum(0.0, 6.0 * (total - 2.0 * moments) / mass))
    return InertiaCheck(name, float(mass), com, I, moments, axes, bool(moments[0] > 0), excess <= INERTIA_ABS_TOL
                        or excess / max(abs(float(np.trace(I))), 1e-300) <= INERTIA_WARN, float(relative), box)


def check_inertias(model) -> tuple[InertiaCheck, ...]:
    """Every body's mass, centre of mass and inertia (``model.masses``, ``coms``, ``inertias``), its principal
    moments and axes, whether it is positive definite and obeys the triangle inequality, and its inertia box."""
    check_model(model)
    masses, coms, inertias = model.masses, model.coms, model.inertias
    return tuple(_check(name, float(masses[i]), np.array(coms[i]), np.array(inertias[i]))
                 for i, name in enumerate(model.body_names))
