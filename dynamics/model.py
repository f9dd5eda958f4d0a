"""The kinematic-tree model: immutable, flat arrays, built once (see :func:`dynamics.load_urdf`).

Bodies are numbered so that ``parents[i] < i`` (depth first from the root, children in document order),
hence every algorithm is one forward and/or one reverse loop over ``range(nbodies)``.  Body ``i`` is moved by
joint ``i``; fixed joints do not appear, their child links are merged into the parent body.  With a fixed
base the URDF root link (and everything welded to it) is the world and is not a body; ``parents[i] == -1``
means "attached to the world".

Array shapes and frames (nb = nbodies):

=================  ===============  =====================================================================
field              shape            meaning
=================  ===============  =====================================================================
parents            (nb,) int64      parent body, -1 for the world
jtype              (nb,) int64      joint code (:mod:`dynamics.joints`)
q_idx, v_idx       (nb,) int64      first coordinate of joint i in q and in v
nv_j               (nb,) int64      number of velocity coordinates of joint i
Xrot, Xpos         (nb,3,3),(nb,3)  joint frame in the parent body frame at q = 0 (rotation, origin)
axis               (nb,3)           unit joint axis in the joint (= body) frame
S                  (nv,6)           motion subspace row per velocity coordinate, (w, v) in the body frame
mass               (nb,)            body mass (kg)
h                  (nb,3)           first moment of mass m*c in the body frame (kg m)
Io                 (nb,3,3)         rotational inertia about the body frame origin, body frame (kg m^2)
XK, XKK            (nb,3,3)         Xrot [axis]x and Xrot [axis]x^2 for revolute and planar joints (zero
                                    otherwise), so that R(q) = Xrot + sin q XK + (1 - cos q) XKK (:mod:`dynamics.joints`)
=================  ===============  =====================================================================

The C++ core's model (``Model.core``, :func:`core_model`) is built once from these arrays, with the model.
"""

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import _core
from .errors import closest
from .joints import (JOINT_NQ, JOINT_NV, KINDS, ROTATES_ABOUT_AXIS, URDF_JOINT_CODES, motion_subspace,
                     revolute_terms)


class Tree(NamedTuple):
    """The model's flat arrays (module docstring), read-only; the core's model is built from them."""

    parents: np.ndarray
    jtype: np.ndarray
    q_idx: np.ndarray
    v_idx: np.ndarray
    nv_j: np.ndarray
    Xrot: np.ndarray
    Xpos: np.ndarray
    axis: np.ndarray
    S: np.ndarray
    mass: np.ndarray
    h: np.ndarray
    Io: np.ndarray
    XK: np.ndarray
    XKK: np.ndarray


class Frames(NamedTuple):
    """Every frame as flat arrays for the kernels (nf = number of frames, in ``model.frame_names`` order)."""

    body: np.ndarray  # (nf,) int64: the body the frame is fixed to, -1 for the world
    kind: np.ndarray  # (nf,) int64: FRAME_BODY, FRAME_SHIFTED, FRAME_ROTATED or FRAME_WORLD (below)
    R: np.ndarray  # (nf, 3, 3): the frame's axes in that body's frame
    p: np.ndarray  # (nf, 3): the frame's origin in that body's frame


#: Frames.kind: the body's own frame (R = 1, p = 0: most link and joint frames); the body's axes at an offset
#: (R = 1); any placement in the body; fixed in the world (body -1).  Known with the model, so that forward
#: kinematics composes each frame with what it needs and no test of R per call.
FRAME_BODY, FRAME_SHIFTED, FRAME_ROTATED, FRAME_WORLD = 0, 1, 2, 3


def frame_kind(body, R, p):
    """The :attr:`Frames.kind` of a frame fixed to ``body`` at (R, p)."""
    if body < 0:
        return FRAME_WORLD
    if not np.array_equal(R, np.eye(3)):
        return FRAME_ROTATED
    return FRAME_SHIFTED if np.any(p != 0.0) else FRAME_BODY


def _frozen(a, dtype=np.float64):
    a = np.ascontiguousarray(a, dtype=dtype)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class Model:
    """A robot as a kinematic tree of rigid bodies.  Immutable; build it with :func:`dynamics.load_urdf`.

    Per-body arrays follow :class:`Tree` (see the module docstring for shapes and frames).  Per velocity
    coordinate arrays (shape (nv,)): ``damping`` (N m s/rad or N s/m), ``friction`` (Coulomb, N m or N),
    ``effort_limit``, ``velocity_limit`` (inf when absent), ``lower``/``upper`` position limits of 1-dof
    joints (-inf/inf when absent, for continuous joints and for the coordinates of free, spherical and planar
    joints).

    Derived once, when the model is built (it is never written to afterwards): ``frame_arrays`` (the frames
    as flat arrays, :class:`Frames`), ``quaternion_starts`` (index in q of each free or spherical joint's
    quaternion), ``unit_blocks`` ((n, 2) int64: start in q and size of each block that is a unit vector, a
    quaternion or a planar joint's (cos, sin); :attr:`JointKind.unit`), the core's model ``core``, and for
    the single-state entry points ``frame_lookup`` (a frame's name -> its index: one dict lookup per call) and the shapes of their results, ``placements_shape``
    (nframes, 4, 4) and ``jacobian_shape`` (6, nv).
    """

    name: str
    nq: int
    nv: int
    tree: Tree
    joint_names: tuple
    joint_types: tuple
    body_names: tuple
    floating_base: bool
    lower: np.ndarray
    upper: np.ndarray
    effort_limit: np.ndarray
    velocity_limit: np.ndarray
    damping: np.ndarray
    friction: np.ndarray
    gravity: np.ndarray
    warnings: tuple = ()
    #: every frame, in a fixed order (see :attr:`frame_names`): name -> (body index or -1 for the world, 4x4 pose
    #: of the frame in that body frame).  Every URDF link and every URDF joint is a frame.
    frames: dict = field(default_factory=dict)
    #: what the model builder merged or left out, as counts and names (see :meth:`summary`)
    info: dict = field(default_factory=dict)
    #: closed loops and coupled joints (:mod:`dynamics.constraints`), added by :func:`dynamics.with_constraints`
    #: or by load_urdf (``<mimic>``, ``<loop>``); empty for a plain tree
    constraints: tuple = ()
    #: the constraints resolved into flat arrays, ``(ConstraintArrays, m)``; set by :func:`dynamics.with_constraints`
    #: with ``constraints`` (:mod:`dynamics.constraints`), None for a plain tree
    constraint_arrays: tuple = None
    #: the contact primitives fixed to the bodies (:class:`dynamics.contact.geometry.CollisionGeometry`: name,
    #: body, frame, kind, size, read-only 4x4 pose in the body), read by ``load_urdf(..., collision=True)`` or
    #: added by :func:`dynamics.add_free_body`; empty otherwise
    collision_geometry: tuple = ()

    def __post_init__(self):
        """What is derived from the fields, computed once here: the model is never written to afterwards."""
        T = np.array([T for _, T in self.frames.values()], float).reshape(-1, 4, 4)
        body = [b for b, _ in self.frames.values()]
        kind = [frame_kind(b, X[:3, :3], X[:3, 3]) for b, X in zip(body, T)]
        object.__setattr__(self, "frame_arrays", Frames(_frozen(body, np.int64), _frozen(kind, np.int64),
                                                        _frozen(T[:, :3, :3]), _frozen(T[:, :3, 3])))
        object.__setattr__(self, "quaternion_starts", _frozen(
            [k + KINDS[c].quaternion for c, k in zip(self.tree.jtype, self.tree.q_idx) if KINDS[c].quaternion >= 0],
            np.int64))
        object.__setattr__(self, "unit_blocks", _frozen(np.array(
            [(k + KINDS[c].unit[0], KINDS[c].unit[1]) for c, k in zip(self.tree.jtype, self.tree.q_idx)
             if KINDS[c].unit], np.int64).reshape(-1, 2), np.int64))
        object.__setattr__(self, "core", core_model(self))
        # frame name -> index, one dict lookup for the single-call entry points (names only: True and 1.0 must not
        # find frame 1); and the shapes of their results
        object.__setattr__(self, "frame_lookup", {n: k for k, n in enumerate(self.frames)})
        object.__setattr__(self, "placements_shape", (len(self.frames), 4, 4))
        object.__setattr__(self, "jacobian_shape", (6, self.nv))

    # -- sizes ---------------------------------------------------------------------------------------
    @property
    def nbodies(self) -> int:
        return self.tree.parents.shape[0]

    # -- convenient views (all read-only) ----------------------------------------------------------
    @property
    def parents(self):
        return self.tree.parents

    @property
    def q_index(self):
        return self.tree.q_idx

    @property
    def v_index(self):
        return self.tree.v_idx

    @property
    def nq_joint(self):
        return _frozen([JOINT_NQ[c] for c in self.tree.jtype], np.int64)

    @property
    def nv_joint(self):
        return self.tree.nv_j

    @property
    def axes(self):
        return self.tree.axis

    @property
    def placements(self):
        """(nb, 4, 4) homogeneous pose of each joint frame in its parent body frame at q = 0."""
        T = np.zeros((self.nbodies, 4, 4))
        T[:, :3, :3] = self.tree.Xrot
        T[:, :3, 3] = self.tree.Xpos
        T[:, 3, 3] = 1.0
        return T

    @property
    def masses(self):
        return self.tree.mass

    @property
    def coms(self):
        """(nb, 3) centre of mass of each body in its body frame (zero for massless bodies)."""
        m = self.tree.mass[:, None]
        return np.divide(self.tree.h, m, out=np.zeros_like(self.tree.h), where=m > 0)

    @property
    def inertias(self):
        """(nb, 3, 3) rotational inertia of each body about its centre of mass, body frame."""
        c = self.coms
        m = self.tree.mass
        out = np.array(self.tree.Io)
        for i in range(self.nbodies):
            out[i] -= m[i] * (np.dot(c[i], c[i]) * np.eye(3) - np.outer(c[i], c[i]))
        return out

    @property
    def spatial_inertias(self):
        """(nb, 6, 6) spatial inertia of each body about its frame origin, (angular, linear) order."""
        out = np.zeros((self.nbodies, 6, 6))
        for i, (m, h, Io) in enumerate(zip(self.tree.mass, self.tree.h, self.tree.Io)):
            hx = np.array([[0, -h[2], h[1]], [h[2], 0, -h[0]], [-h[1], h[0], 0]])
            out[i] = np.block([[Io, hx], [hx.T, m * np.eye(3)]])
        return out

    @property
    def frame_names(self) -> tuple:
        """Names of every frame: URDF links and joints, depth first from the root link, each joint just before
        its child link (whose frame it shares), a floating base's ``root_joint`` first.  A joint named like a
        link is listed as ``joint:NAME`` (the plain name is the link's, as in Pinocchio's getFrameId)."""
        return tuple(self.frames)

    def frame_index(self, name: str) -> int:
        """Index of the frame named ``name`` in :attr:`frame_names`; an unknown name is an
        :class:`~dynamics.InputError` listing the closest names."""
        k = self.frame_lookup.get(name) if isinstance(name, str) else None
        if k is None:
            raise closest(name, list(self.frames), "frame")
        return k

    @property
    def total_mass(self) -> float:
        """Mass of all bodies (kg); links welded to the world (a fixed base's root) are not bodies."""
        return float(np.sum(self.tree.mass))

    def joint_index(self, name: str) -> int:
        """Index of the movable joint (= body) named ``name``; an unknown name lists the closest names."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise closest(name, self.joint_names, "joint") from None

    def q_slice(self, name: str) -> slice:
        """The coordinates of joint ``name`` in q: ``q[model.q_slice("elbow")]``."""
        i = self.joint_index(name)
        return slice(int(self.tree.q_idx[i]), int(self.tree.q_idx[i]) + JOINT_NQ[int(self.tree.jtype[i])])

    def v_slice(self, name: str) -> slice:
        """The coordinates of joint ``name`` in v, a and tau."""
        i = self.joint_index(name)
        return slice(int(self.tree.v_idx[i]), int(self.tree.v_idx[i]) + int(self.tree.nv_j[i]))

    def neutral(self) -> np.ndarray:
        """The neutral configuration: zero for each 1-dof joint whose limits allow it, else the middle of its
        range (the bound, when only one is finite), as MuJoCo clamps ``qpos0`` into the limits; the identity
        quaternion for a free joint.  Panda's joint 4 (limits [-3.07, -0.07] rad) thus starts at -1.571, the
        elbow bent, not at 0, outside its range and singular.  Pinocchio's ``neutral`` is zero there.  A
        spherical joint's neutral is the identity quaternion, a planar joint's (0, 0, cos 0, sin 0)."""
        q = np.zeros(self.nq)
        for code, k, kv in zip(self.tree.jtype, self.tree.q_idx, self.tree.v_idx):
            kind = KINDS[code]
            q[k:k + kind.nq] = kind.neutral
            if not kind.limited:
                continue
            lo, hi = float(self.lower[kv]), float(self.upper[kv])
            if not lo <= 0.0 <= hi:  # a finite bound lies on the side zero left
                q[k] = (lo + hi) / 2 if np.isfinite(lo) and np.isfinite(hi) else (lo if np.isfinite(lo) else hi)
        return q

    def summary(self) -> dict:
        """What the model contains and what the builder merged or left out (JSON-serialisable)."""
        out = {
            "name": self.name,
            "nq": self.nq,
            "nv": self.nv,
            "bodies": self.nbodies,
            "floating_base": self.floating_base,
            # movable joints per URDF type (revolute, continuous, prismatic, floating, planar, spherical)
            "joint_types": {t: self.joint_types.count(t) for t in dict.fromkeys(self.joint_types)},
        }
        out.update(self.info)
        out["warnings"] = list(self.warnings)
        return out

    def __getstate__(self):
        """Pickling (process pools, Ray): the fields, without the core's model, which unpickling builds again."""
        return {k: v for k, v in self.__dict__.items() if k != "core"}

    def __setstate__(self, state):
        """Unpickling (process pools, Ray) gives writable arrays: freeze them again (a model is never written to),
        with numpy's own dtype objects (``dtype.type``), as a new model's are, and build the core's model."""
        for key, value in state.items():
            if isinstance(value, (Tree, Frames)):
                value = type(value)(*(_frozen(a, a.dtype.type) for a in value))
            elif key == "constraint_arrays" and value is not None:
                C, m = value
                value = (type(C)(*(_frozen(a, a.dtype.type) for a in C)), m)
            elif isinstance(value, np.ndarray):
                value = _frozen(value, value.dtype.type)
            elif key == "collision_geometry":
                value = tuple(g._replace(pose=_frozen(g.pose)) for g in value)
            object.__setattr__(self, key, value)
        object.__setattr__(self, "core", core_model(self))

    def __repr__(self):
        return (f"Model({self.name!r}, nq={self.nq}, nv={self.nv}, bodies={self.nbodies}, "
                f"floating_base={self.floating_base})")


def core_model(model):
    """The C++ core's model (``dynamics._core.Model``) of ``model``'s arrays: built once with the model, shared by
    every thread (the core checks every index and size; an inconsistent model is a ValueError here)."""
    t, fr = model.tree, model.frame_arrays
    return _core.Model(t.parents, t.jtype, t.q_idx, t.v_idx, t.nv_j, t.Xrot, t.Xpos, t.axis, t.S, t.mass, t.h, t.Io,
                       t.XK, t.XKK, model.gravity, model.lower, model.upper, fr.body, fr.kind, fr.R, fr.p)


@dataclass
class BodySpec:
    """One body of a model under construction (used by the URDF loader, reductions and tests).

    ``placement`` is the 4x4 pose of the joint frame in the parent body frame at q = 0; the inertia is
    (mass, h = m c, Io about the body origin) in the body frame.
    """

    name: str
    joint_name: str
    joint_type: str  # "revolute" | "continuous" | "prismatic" | "floating" | "spherical" | "planar"
    parent: int
    placement: np.ndarray
    axis: np.ndarray
    mass: float = 0.0
    h: np.ndarray = field(default_factory=lambda: np.zeros(3))
    Io: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    lower: float = -np.inf
    upper: float = np.inf
    effort: float = np.inf
    velocity: float = np.inf
    damping: float = 0.0
    friction: float = 0.0


def build_model(name, bodies, *, floating_base, gravity=(0.0, 0.0, -9.81), warnings=(), frames=None,
                info=None) -> Model:
    """Assemble the flat arrays of a :class:`Model` from body specs ordered with parents first."""
    nb = len(bodies)
    codes = [URDF_JOINT_CODES[b.joint_type] for b in bodies]
    for i, b in enumerate(bodies):
        if not -1 <= b.parent < i:
            raise ValueError(f"body {b.name!r}: parent index {b.parent} must be in [-1, {i})")
    nq_j = [JOINT_NQ[c] for c in codes]
    nv_j = [JOINT_NV[c] for c in codes]
    q_idx = np.concatenate([[0], np.cumsum(nq_j)[:-1]]).astype(np.int64) if nb else np.zeros(0, np.int64)
    v_idx = np.concatenate([[0], np.cumsum(nv_j)[:-1]]).astype(np.int64) if nb else np.zeros(0, np.int64)
    nv = int(sum(nv_j))
    S = np.concatenate([motion_subspace(c, np.asarray(b.axis, float)) for c, b in zip(codes, bodies)]) \
        if nb else np.zeros((0, 6))
    per_dof = {k: [] for k in ("lower", "upper", "effort", "velocity", "damping", "friction")}
    for c, b, n in zip(codes, bodies, nv_j):
        for k in per_dof:
            value = getattr(b, k)
            if not KINDS[c].limited:  # free, spherical and planar joints: no URDF limits or damping
                value = {"lower": -np.inf, "upper": np.inf, "effort": np.inf, "velocity": np.inf}.get(k, 0.0)
            per_dof[k].extend([value] * n)
    P = np.array([b.placement for b in bodies]).reshape(nb, 4, 4)
    XK, XKK = np.zeros((nb, 3, 3)), np.zeros((nb, 3, 3))
    for i, (c, b) in enumerate(zip(codes, bodies)):
        if c in ROTATES_ABOUT_AXIS:
            XK[i], XKK[i] = revolute_terms(P[i, :3, :3], b.axis)
    tree = Tree(
        parents=_frozen([b.parent for b in bodies], np.int64),
        jtype=_frozen(codes, np.int64),
        q_idx=_frozen(q_idx, np.int64),
        v_idx=_frozen(v_idx, np.int64),
        nv_j=_frozen(nv_j, np.int64),
        Xrot=_frozen(P[:, :3, :3]),
        Xpos=_frozen(P[:, :3, 3]),
        axis=_frozen(np.array([b.axis for b in bodies], float).reshape(nb, 3)),
        S=_frozen(S.reshape(nv, 6)),
        mass=_frozen([b.mass for b in bodies]),
        h=_frozen(np.array([b.h for b in bodies], float).reshape(nb, 3)),
        Io=_frozen(np.array([b.Io for b in bodies], float).reshape(nb, 3, 3)),
        XK=_frozen(XK),
        XKK=_frozen(XKK),
    )
    return Model(
        name=name,
        nq=int(sum(nq_j)),
        nv=nv,
        tree=tree,
        joint_names=tuple(b.joint_name for b in bodies),
        joint_types=tuple(b.joint_type for b in bodies),
        body_names=tuple(b.name for b in bodies),
        floating_base=floating_base,
        lower=_frozen(per_dof["lower"]),
        upper=_frozen(per_dof["upper"]),
        effort_limit=_frozen(per_dof["effort"]),
        velocity_limit=_frozen(per_dof["velocity"]),
        damping=_frozen(per_dof["damping"]),
        friction=_frozen(per_dof["friction"]),
        gravity=_frozen(gravity),
        warnings=tuple(warnings),
        frames=dict(frames or {}),
        info=dict(info or {}),
    )
