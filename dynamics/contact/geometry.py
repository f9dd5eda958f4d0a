"""Contact geometry as the user writes it: the robot's primitives and the world's.

Two kinds of record:

* :class:`CollisionGeometry`: one resolved primitive of a model (``model.collision_geometry``, read from the
  URDF ``<collision>`` elements by ``load_urdf(..., collision=True)``, or appended by
  :func:`dynamics.add_free_body`): the body it is fixed to (-1 = the world), its kind, size and 4x4 pose in
  that body's frame.
* The declarations, frozen dataclasses checked when they are made (an :class:`~dynamics.InputError` naming
  the field): :class:`Sphere`, :class:`Box`, :class:`Capsule`, :class:`Cylinder`, :class:`ContactPoint` fixed
  to a model frame (a link or joint frame, or ``"world"`` for a static object), and the world's
  :class:`Ground` and :class:`HalfSpace`.  :func:`dynamics.contact.scene.build_scene` resolves them against a
  model.

Sizes follow URDF: a box's ``size`` is its full edge lengths (x, y, z); a capsule and a cylinder have their
axis along their local z, ``length`` between the centres of the end caps (a capsule's overall length is
``length + 2 radius``, as URDF and ROS write capsules), centred at their pose's origin.

A half-space is the solid below its plane: the points x with ``normal . x <= height`` (``offset`` for
:class:`HalfSpace`), the normal pointing out of the solid, into the free space; it is normalised when made.
"""

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import InputError

#: the kinds of primitive, as ``CollisionGeometry.kind`` names them
KINDS = ("sphere", "box", "capsule", "cylinder", "point")
#: largest size or offset accepted (m): beyond it a number is a unit error, and squares of it still fit a float
MAX_LENGTH = 1e6


class CollisionGeometry(NamedTuple):
    """One primitive fixed to a body of a model.

    ``size``: sphere (radius, 0, 0); box full edge lengths (x, y, z); capsule and cylinder (radius, length, 0),
    axis along local z; point (0, 0, 0).  ``pose``: read-only 4x4 pose of the primitive in the frame of
    ``body`` (-1 = the world: then the world pose).  ``frame``: the link (or frame) it was declared on.
    """

    name: str
    body: int
    frame: str
    kind: str
    size: tuple
    pose: np.ndarray


def frozen_pose(T, what):
    """T (None = identity) as a read-only 4x4 rigid pose, or an InputError naming ``what``."""
    if T is None:
        T = np.eye(4)
    try:
        T = np.array(T, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected a 4x4 pose (array of numbers), got {type(T).__name__}") from None
    if T.shape != (4, 4):
        raise InputError(f"{what}: expected a 4x4 pose, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise InputError(f"{what}: the pose has a NaN or infinite entry")
    if np.abs(T[:3, 3]).max() > MAX_LENGTH:
        raise InputError(f"{what}: the pose's translation exceeds {MAX_LENGTH:.0e} m")
    R = T[:3, :3]
    if not np.allclose(T[3], (0, 0, 0, 1)) or np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
        raise InputError(f"{what}: the pose's rotation is not a rotation (R^T R = 1, det R = 1, last row 0 0 0 1)")
    T[3] = (0.0, 0.0, 0.0, 1.0)
    T.flags.writeable = False
    return T


def translation(p, what):
    """A 4x4 read-only pose translated by p (3 finite numbers)."""
    T = np.eye(4)
    T[:3, 3] = vector3(p, what)
    T.flags.writeable = False
    return T


def vector3(x, what):
    """x as 3 finite floats (a tuple), or an InputError naming ``what``."""
    try:
        a = np.array(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected 3 numbers, got {type(x).__name__}") from None
    if a.shape != (3,):
        raise InputError(f"{what}: expected 3 numbers, got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.abs(a).max() > MAX_LENGTH:
        raise InputError(f"{what}: expected 3 finite numbers of at most {MAX_LENGTH:.0e}, got {a.tolist()}")
    return tuple(float(v) for v in a)


def length(x, what, *, positive=True):
    """x as a float in (0, MAX_LENGTH] (or [0, ...] with positive=False), or an InputError naming ``what``."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise InputError(f"{what}: expected a number, got {type(x).__name__}")
    x = float(x)
    if not np.isfinite(x) or x < 0 or (positive and x == 0) or x > MAX_LENGTH:
        raise InputError(f"{what}: expected a finite number {'>' if positive else '>='} 0 and <= "
                         f"{MAX_LENGTH:.0e} (m), got {x}")
    return x


def _frame(frame, what):
    if not isinstance(frame, str) or not frame:
        raise InputError(f"{what}.frame: expected a frame name (str) or 'world', got {frame!r:.60}")
    return frame


def _name(name, what):
    if name is not None and (not isinstance(name, str) or not name or len(name) > 256):
        raise InputError(f"{what}.name: expected a non-empty str of at most 256 characters or None, got "
                         f"{name!r:.60}")
    return name


@dataclass(frozen=True)
class Sphere:
    """A sphere of ``radius`` (m) centred at ``offset`` (3 numbers) in ``frame`` (a model frame or "world")."""

    frame: str
    radius: float
    offset: tuple = (0.0, 0.0, 0.0)
    name: str = None

    def __post_init__(self):
        object.__setattr__(self, "frame", _frame(self.frame, "Sphere"))
        object.__setattr__(self, "radius", length(self.radius, "Sphere.radius"))
        object.__setattr__(self, "offset", vector3(self.offset, "Sphere.offset"))
        object.__setattr__(self, "name", _name(self.name, "Sphere"))

    kind = "sphere"

    @property
    def size(self):
        return (self.radius, 0.0, 0.0)

    @property
    def pose(self):
        return translation(self.offset, "Sphere.offset")


@dataclass(frozen=True, eq=False)
class Box:
    """A box of full edge lengths ``size`` (x, y, z, m) at ``pose`` (4x4 in ``frame``; None = the frame's own
    pose).  ``Box("world", size, pose)`` is a static box (a step, a table)."""

    frame: str
    size: tuple
    pose: np.ndarray = None
    name: str = None

    def __post_init__(self):
        object.__setattr__(self, "frame", _frame(self.frame, "Box"))
        size = vector3(self.size, "Box.size")
        if min(size) <= 0:
            raise InputError(f"Box.size: expected 3 edge lengths > 0 (m), got {list(size)}")
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "pose", frozen_pose(self.pose, "Box.pose"))
        object.__setattr__(self, "name", _name(self.name, "Box"))

    kind = "box"


@dataclass(frozen=True, eq=False)
class _Axial:
    """A solid of ``radius`` around the segment of ``length`` along the local z axis of ``pose`` (4x4 in
    ``frame``, None = identity), centred at its origin: the fields and checks a capsule and a cylinder share."""

    frame: str
    radius: float
    length: float
    pose: np.ndarray = None
    name: str = None
    kind = None
    _flat_allowed = False  # may the length be 0 (a capsule of length 0 is a sphere; a cylinder must have one)

    def __post_init__(self):
        what = type(self).__name__
        object.__setattr__(self, "frame", _frame(self.frame, what))
        object.__setattr__(self, "radius", length(self.radius, f"{what}.radius"))
        object.__setattr__(self, "length", length(self.length, f"{what}.length", positive=not self._flat_allowed))
        object.__setattr__(self, "pose", frozen_pose(self.pose, f"{what}.pose"))
        object.__setattr__(self, "name", _name(self.name, what))

    @property
    def size(self):
        return (self.radius, self.length, 0.0)


@dataclass(frozen=True, eq=False)
class Capsule(_Axial):
    """A capsule: the points within ``radius`` of the segment of ``length`` along the local z axis of ``pose``
    (4x4 in ``frame``, None = identity), centred at its origin (overall length ``length + 2 radius``)."""

    kind = "capsule"
    _flat_allowed = True


@dataclass(frozen=True, eq=False)
class Cylinder(_Axial):
    """A solid cylinder of ``radius`` and ``length`` along the local z axis of ``pose`` (as URDF's), centred at
    its origin."""

    kind = "cylinder"


@dataclass(frozen=True)
class ContactPoint:
    """A point (3 numbers, m) fixed in ``frame``: touches planes, half-spaces and the other primitives as a
    sphere of radius zero (a foot's sole corner, a fingertip)."""

    frame: str
    point: tuple
    name: str = None

    def __post_init__(self):
        object.__setattr__(self, "frame", _frame(self.frame, "ContactPoint"))
        object.__setattr__(self, "point", vector3(self.point, "ContactPoint.point"))
        object.__setattr__(self, "name", _name(self.name, "ContactPoint"))

    kind = "point"
    size = (0.0, 0.0, 0.0)

    @property
    def pose(self):
        return translation(self.point, "ContactPoint.point")


def unit_normal(normal, what):
    """normal (3 finite numbers, nonzero) scaled to unit length, as a tuple."""
    n = np.array(vector3(normal, what))
    big = np.abs(n).max()
    if big == 0.0:
        raise InputError(f"{what}: the normal is zero; expected a nonzero vector")
    n = n / big
    n = n / np.linalg.norm(n)
    return tuple(float(v) for v in n)


def _height(h, what):
    if isinstance(h, bool) or not isinstance(h, (int, float, np.integer, np.floating)) or not np.isfinite(h) \
            or abs(float(h)) > MAX_LENGTH:
        raise InputError(f"{what}: expected a finite number of at most {MAX_LENGTH:.0e} (m), got {h!r:.40}")
    return float(h)


@dataclass(frozen=True)
class Ground:
    """The ground: the half-space ``normal . x <= height`` (the normal is normalised; z up by default).  An
    incline is a ground with a tilted normal."""

    normal: tuple = (0.0, 0.0, 1.0)
    height: float = 0.0
    name: str = "ground"

    def __post_init__(self):
        object.__setattr__(self, "normal", unit_normal(self.normal, "Ground.normal"))
        object.__setattr__(self, "height", _height(self.height, "Ground.height"))
        object.__setattr__(self, "name", _name(self.name, "Ground") or "ground")

    @property
    def offset(self):
        return self.height


@dataclass(frozen=True)
class HalfSpace:
    """A static half-space ``normal . x <= offset`` (a wall, an incline, the side of a step): the same
    convention as :class:`Ground`, the normal pointing into the free space."""

    normal: tuple
    offset: float = 0.0
    name: str = None

    def __post_init__(self):
        object.__setattr__(self, "normal", unit_normal(self.normal, "HalfSpace.normal"))
        object.__setattr__(self, "offset", _height(self.offset, "HalfSpace.offset"))
        object.__setattr__(self, "name", _name(self.name, "HalfSpace"))


#: the declarations fixed to a frame
PRIMITIVES = (Sphere, Box, Capsule, Cylinder, ContactPoint)
#: the world's planes
PLANES = (Ground, HalfSpace)
