"""Closed loops and coupled joints: declarations, and the residual phi(q), its Jacobian Phi_q and Phi_q_dot v.

A constrained model adds m equations phi(q) = 0 to the tree (the lectures' parallel mechanisms, the four-bar
first).  Each declaration is resolved once into two *anchors* fixed on bodies, a (body_a, R_a, p_a) and
(body_b, R_b, p_b) pose in the body frames (:class:`ConstraintArrays`), and gives rows of phi, all in
**world axes**, with x_A, x_B the anchors' world origins, R_A, R_B their world axes:

===================  ====  ====================================================================================
declaration          rows  phi(q) and the velocity rows Phi_q v
===================  ====  ====================================================================================
PointConstraint      3     x_A - x_B;                    v_A(x_A) - v_B(x_B)
WeldConstraint       6     [x_A - x_B; log(R_A R_B^T)];  [v_A(x_A) - v_B(x_B); w_A - w_B]
RevoluteConstraint   5     [x_A - x_B; t_k . (u_B x u_A)];  [v_A(x_A) - v_B(x_B); t_k . (w_A - w_B)], k = 1, 2
JointCoupling        1     q_f - (multiplier q_l + offset);  v_f - multiplier v_l
===================  ====  ====================================================================================

u_A, u_B are the hinge axis on each body (the anchors' z axes) and t_1, t_2 the anchor-a axes normal to it
(x and y).  The velocity rows are exact for the point and coupling rows everywhere; for the angular rows of
the weld and the hinge they are the derivative of phi on the manifold phi = 0 (to first order near it),
which is all the dynamics, Baumgarte's terms and Newton's method need.  Phi_q_dot v (:func:`constraint_bias`)
is the time derivative of Phi_q v at a = 0: the difference of the anchors' classical bias accelerations
(Jdot v of :mod:`dynamics.kinematics`), and for the hinge rows (w_A x t_k) . (w_A - w_B) + t_k . (alpha_A -
alpha_B), so that d/dt (Phi_q v) = Phi_q a + Phi_q_dot v exactly.

Multipliers (:mod:`dynamics.constrained_dynamics`) enter as M a + C v + g = tau + Phi_q^T lambda: the rows of lambda are
then, in world axes, the force [N] exerted on body a at x_A (and its opposite on body b at x_B), the torque
[N m] on body a (weld: 3 components; hinge: about t_1 and t_2), and for a coupling the generalised force on
the follower joint [N m or N] (its reaction, -multiplier times it, acts on the leader).

Kinematics run in world coordinates (Featherstone 2008, sec. 2.9): motion axes oS_k = (oR_i S_w, oR_i S_v +
op_i x oR_i S_w) at the world origin, V_i = V_p + oS_i qd_i, bias acceleration A_i = A_p + V_i x oS_i qd_i.
"""

import warnings as _warnings
import weakref
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from . import _core, checks
from .errors import DeadlineExceeded, InputError
from .kinematics import frame_placement
from .model import _frozen
from .parallel import num_threads, seconds_left

POINT, WELD, REVOLUTE, COUPLING = 0, 1, 2, 3
#: rows per constraint kind
ROWS = {POINT: 3, WELD: 6, REVOLUTE: 5, COUPLING: 1}
#: largest |multiplier| and |offset| of a JointCoupling.  Mimic multipliers are gear ratios (1 to a few hundred
#: in published URDFs) and offsets joint positions (radians or metres).  The coupling row (1, -multiplier) makes
#: the constrained dynamics' K = Phi_q M^-1 Phi_q^T as ill-conditioned as multiplier^2 (1e8 here: half the
#: float64 digits left), and a follower at |q| ~ offset has a float spacing of offset * 2.2e-16 (2.2e-12 here),
#: which must stay far below the assembly tolerance of 1e-10; at 1e308 neither holds and q = [0, 1e308, 0]
#: "satisfies" the coupling.
MAX_COUPLING = 1e4
#: a start off the constraints, or a drift during a simulation, beyond this (m, rad, or a coupled joint's units)
#: is reported: a micrometre is far above what Baumgarte's terms and the integrator's default tolerances leave
#: (the four-bar stays below 1e-7 over 10 s), and far below an opened loop that changes the motion
MANIFOLD_TOL = 1e-6


# -- declarations ----------------------------------------------------------------------------------------------

def _vec3(name, x):
    return tuple(float(c) for c in checks.vector(name, x, 3))


def _name(what, x):
    if not isinstance(x, str) or not x:
        raise InputError(f"{what}: expected a frame or joint name (a non-empty str), got {x!r}")
    return x


@dataclass(frozen=True)
class PointConstraint:
    """A spherical closure (3 rows): ``point_a`` on frame_a coincides with ``point_b`` on frame_b (each in its
    frame's coordinates)."""

    frame_a: str
    frame_b: str
    point_a: tuple = (0.0, 0.0, 0.0)
    point_b: tuple = (0.0, 0.0, 0.0)
    name: str = ""
    rows = 3

    def __post_init__(self):
        object.__setattr__(self, "frame_a", _name("PointConstraint frame_a", self.frame_a))
        object.__setattr__(self, "frame_b", _name("PointConstraint frame_b", self.frame_b))
        object.__setattr__(self, "point_a", _vec3("PointConstraint point_a", self.point_a))
        object.__setattr__(self, "point_b", _vec3("PointConstraint point_b", self.point_b))


@dataclass(frozen=True)
class WeldConstraint:
    """A rigid closure (6 rows): frame_b keeps the pose ``placement`` (4x4) in frame_a.  ``placement=None``:
    the relative pose at assembly (the configuration ``at`` given to :func:`with_constraints`)."""

    frame_a: str
    frame_b: str
    placement: object = None
    name: str = ""
    rows = 6

    def __post_init__(self):
        object.__setattr__(self, "frame_a", _name("WeldConstraint frame_a", self.frame_a))
        object.__setattr__(self, "frame_b", _name("WeldConstraint frame_b", self.frame_b))
        if self.placement is not None:
            T, batched = checks.poses("WeldConstraint placement", self.placement)
            if batched:
                raise InputError("WeldConstraint placement: expected one (4, 4) pose")
            object.__setattr__(self, "placement", tuple(map(tuple, T[0])))


@dataclass(frozen=True)
class RevoluteConstraint:
    """A hinge closure (5 rows): ``point_a`` on frame_a coincides with ``point_b`` on frame_b and the hinge
    ``axis`` (frame_a's coordinates) stays parallel to ``axis_b`` (frame_b's coordinates; default: the same
    numbers as ``axis``)."""

    frame_a: str
    frame_b: str
    axis: tuple = (0.0, 0.0, 1.0)
    point_a: tuple = (0.0, 0.0, 0.0)
    point_b: tuple = (0.0, 0.0, 0.0)
    axis_b: tuple = None
    name: str = ""
    rows = 5

    def __post_init__(self):
        object.__setattr__(self, "frame_a", _name("RevoluteConstraint frame_a", self.frame_a))
        object.__setattr__(self, "frame_b", _name("RevoluteConstraint frame_b", self.frame_b))
        object.__setattr__(self, "point_a", _vec3("RevoluteConstraint point_a", self.point_a))
        object.__setattr__(self, "point_b", _vec3("RevoluteConstraint point_b", self.point_b))
        for attr, x in (("axis", self.axis), ("axis_b", self.axis if self.axis_b is None else self.axis_b)):
            u = np.array(_vec3(f"RevoluteConstraint {attr}", x))
            if np.linalg.norm(u) < 1e-12:
                raise InputError(f"RevoluteConstraint {attr}: the hinge axis is zero; expected a non-zero 3-vector")
            object.__setattr__(self, attr, tuple(float(c) for c in u / np.linalg.norm(u)))


@dataclass(frozen=True)
class JointCoupling:
    """q_follower = multiplier * q_leader + offset (1 row): what a URDF ``<mimic>`` means.  Both joints are
    1-dof (revolute, continuous or prismatic)."""

    follower: str
    leader: str
    multiplier: float = 1.0
    offset: float = 0.0
    name: str = ""
    rows = 1

    def __post_init__(self):
        object.__setattr__(self, "follower", _name("JointCoupling follower", self.follower))
        object.__setattr__(self, "leader", _name("JointCoupling leader", self.leader))
        for attr in ("multiplier", "offset"):
            x = checks.real_number(f"JointCoupling {attr}", getattr(self, attr))
            if abs(x) > MAX_COUPLING:
                raise InputError(f"JointCoupling {attr}: |{attr}| = {abs(x):.3g} exceeds {MAX_COUPLING:.0e}, more "
                                 f"than float64 dynamics can carry (the coupling's conditioning grows as the "
                                 f"multiplier squared, the follower's round-off as the offset); expected a gear "
                                 f"ratio and an offset in the joints' units (radians or metres)")
            object.__setattr__(self, attr, x)
        if self.follower == self.leader:
            raise InputError(f"JointCoupling: joint {self.follower!r} cannot follow itself")


KINDS = {PointConstraint: POINT, WeldConstraint: WELD, RevoluteConstraint: REVOLUTE, JointCoupling: COUPLING}


class ConstraintArrays(NamedTuple):
    """The constraints as flat arrays for the kernels (nc constraints, m rows)."""

    kind: np.ndarray  # (nc,) int64: POINT, WELD, REVOLUTE or COUPLING
    row: np.ndarray  # (nc,) int64: the constraint's first row in phi
    body: np.ndarray  # (nc, 2) int64: the bodies of anchors a and b (-1: the world)
    R: np.ndarray  # (nc, 2, 3, 3): the anchors' axes in their bodies' frames (hinge: z = the axis)
    p: np.ndarray  # (nc, 2, 3): the anchors' origins in their bodies' frames
    idx: np.ndarray  # (nc, 4) int64: coupling (q index, v index) of the follower, then of the leader
    coef: np.ndarray  # (nc, 2): coupling (multiplier, offset)


def _basis(u):
    """A rotation whose z column is the unit vector u (x, y complete a right-handed frame)."""
    u = np.asarray(u, float)
    t = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(t, u)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(u, x), u])


def _anchor(model, frame, R, p):
    """(body, pose in the body frame) of a pose (R, p) given in ``frame``'s coordinates."""
    body, T = model.frames[model.frame_names[checks.frame(model, frame)]]
    return body, T[:3, :3] @ R, T[:3, :3] @ p + T[:3, 3]


def _joint(model, name, what):
    i = model.joint_index(name)
    if model.nv_joint[i] != 1:
        raise InputError(f"{what}: joint {name!r} is a {model.joint_types[i]} joint; a coupling needs 1-dof joints")
    return int(model.q_index[i]), int(model.v_index[i])


def resolve(model, constraints, placements):
    """Flat arrays of ``constraints`` on ``model``; ``placements[k]`` is weld k's placement (4x4) or None."""
    nc = len(constraints)
    kind, row = np.zeros(nc, np.int64), np.zeros(nc, np.int64)
    body, R, p = np.full((nc, 2), -1, np.int64), np.tile(np.eye(3), (nc, 2, 1, 1)), np.zeros((nc, 2, 3))
    idx, coef = np.zeros((nc, 4), np.int64), np.zeros((nc, 2))
    m = 0
    for c, con in enumerate(constraints):
        kind[c], row[c] = KINDS[type(con)], m
        m += con.rows
        if kind[c] == COUPLING:
            idx[c, :2] = _joint(model, con.follower, "JointCoupling follower")
            idx[c, 2:] = _joint(model, con.leader, "JointCoupling leader")
            coef[c] = con.multiplier, con.offset
            continue
        eye, zero = np.eye(3), np.zeros(3)
        if kind[c] == POINT:
            a, b = (eye, np.array(con.point_a)), (eye, np.array(con.point_b))
        elif kind[c] == WELD:
            T = np.array(placements[c])
            a, b = (T[:3, :3], T[:3, 3]), (eye, zero)
        else:
            a, b = (_basis(con.axis), np.array(con.point_a)), (_basis(con.axis_b), np.array(con.point_b))
        body[c, 0], R[c, 0], p[c, 0] = _anchor(model, con.frame_a, *a)
        body[c, 1], R[c, 1], p[c, 1] = _anchor(model, con.frame_b, *b)
    arrays = ConstraintArrays(_frozen(kind, np.int64), _frozen(row, np.int64), _frozen(body, np.int64),
                              _frozen(R), _frozen(p), _frozen(idx, np.int64), _frozen(coef))
    return arrays, m


def arrays(model):
    """The model's constraints as :class:`ConstraintArrays` and m: resolved once by :func:`with_constraints` and
    kept in the model (``model.constraint_arrays``); resolved here for a model built otherwise."""
    if model.constraint_arrays is not None:
        return model.constraint_arrays
    return resolve(model, model.constraints, [getattr(c, "placement", None) for c in model.constraints])


#: the core's Constraints of each resolved ConstraintArrays, by id of its ``kind`` array (dropped with it)
_CORE = {}


def core_constraints(model):
    """The C++ core's constraints (``dynamics._core.Constraints``) of ``model``: built once from the resolved
    :class:`ConstraintArrays` (kept with the model by :func:`with_constraints`) and kept as long as they live."""
    C, m = arrays(model)
    key = id(C.kind)
    hit = _CORE.get(key)
    if hit is not None and hit[0]() is C.kind:
        return hit[1]
    core = _core.Constraints(model.core, C.kind, C.row, C.body, np.ascontiguousarray(C.R, float),
                             np.ascontiguousarray(C.p, float), C.idx, np.ascontiguousarray(C.coef, float), m)
    _CORE[key] = (weakref.ref(C.kind), core)
    weakref.finalize(C.kind, _CORE.pop, key, None)
    return core


def run_core(kernel, model, *args, out):
    """``kernel(model.core, core_constraints(model), *args, out, threads, seconds)`` into ``out``, inside the
    deadline of :func:`dynamics.parallel.deadline`; returns the failed state and its body, or (-1, -1)."""
    B = out.shape[0]
    done, expired, failed, body = kernel(model.core, core_constraints(model), *args, out, num_threads(), seconds_left())
    if expired:
        raise DeadlineExceeded(f"the batch of {B} states ran past its deadline; {done} were done", done=done, total=B)
    return failed, body


def with_constraints(model, constraints, *, at=None):
    """A new model with ``constraints`` added to ``model.constraints`` (immutable, like :func:`lock_joints`).

    ``constraints``: PointConstraint, WeldConstraint, RevoluteConstraint and JointCoupling declarations.
    ``at``: the assembly configuration, where a WeldConstraint without ``placement`` takes its relative pose
    (default: ``model.neutral()``).  Unknown frames or joints are an :class:`~dynamics.InputError` listing the
    closest names.  The loops are closed near ``at`` by Gauss-Newton (:func:`dynamics.assemble`'s iteration);
    where they close, a set of constraints that leaves nothing free to move (rank of Phi_q = nv) is refused
    with the rank.  ``model.info["constraints"]`` records rows, rank and mobility there (or at ``at`` when the
    loops do not close near it: ``closed_near_assembly`` False).

    What can never hold is refused (:func:`refuse_never_holding`): a loop whose two anchors are on one rigid
    body, anchors farther apart than the chain between them can ever bring together, couplings in a cycle.  A
    warning (``model.warnings`` and Python's ``warnings``) when the loops do not close near ``at``, and for
    constraints whose rows repeat those before them (redundant rows: their multipliers are not unique).
    """
    checks.check_model(model)
    if isinstance(constraints, (PointConstraint, WeldConstraint, RevoluteConstraint, JointCoupling)):
        constraints = [constraints]
    try:
        constraints = list(constraints)
    except TypeError:
        raise InputError(f"constraints: expected a list of constraint declarations, got "
                         f"{type(constraints).__name__}") from None
    for k, c in enumerate(constraints):
        if type(c) not in KINDS:
            raise InputError(f"constraints[{k}]: expected PointConstraint, WeldConstraint, RevoluteConstraint "
                             f"or JointCoupling, got {type(c).__name__}")
    q0 = model.neutral() if at is None else checks.vector("at", at, model.nq)
    resolve(model, constraints, [np.eye(4)] * len(constraints))  # names checked before any kinematics
    fixed = []
    for c in constraints:
        if isinstance(c, WeldConstraint) and c.placement is None:
            Ta = frame_placement(model, q0, c.frame_a)
            Tb = frame_placement(model, q0, c.frame_b)
            c = replace(c, placement=np.linalg.solve(Ta, Tb))
        fixed.append(c)
    out = replace(model, constraints=tuple(model.constraints) + tuple(fixed), info=dict(model.info),
                  constraint_arrays=None)
    C, m = arrays(out)
    out = replace(out, constraint_arrays=(C, m))
    refuse_never_holding(out, out.constraints, C)
    J, err = _close_near(out, C, m, q0)
    tol = 1e-9 * max(1.0, np.abs(J).max(initial=0.0))
    rank = int(np.linalg.matrix_rank(J, tol=tol)) if m else 0
    if m and model.nv and rank >= model.nv and err <= 1e-10:
        raise InputError(f"constraints: over-constrained: the {m} constraint rows have rank {rank} = nv = "
                         f"{model.nv} where the loops close, so nothing can move; remove constraints or unlock "
                         f"joints")
    out.info["constraints"] = {"count": len(out.constraints), "rows": m, "rank": rank,
                               "mobility": model.nv - rank, "closed_near_assembly": bool(err <= 1e-10)}
    notes = _coupling_range_notes(out, len(model.constraints)) + _assembly_notes(out.constraints, C, J, tol, err)
    if notes:
        out = replace(out, warnings=tuple(out.warnings) + tuple(notes))
        for note in notes:
            _warnings.warn(note, UserWarning, stacklevel=2)
    return out


def _close_near(model, C, m, q0):
    """(Phi_q, max |phi|) where Gauss-Newton from q0 (then from nearby starts) closes the loops, or gets nearest."""
    if np.all(C.kind == COUPLING):  # constant rows, always closable: no kinematics needed to load a gripper
        return coupling_rows(C, m, model.nv), 0.0
    q1, err = q0, 0.0
    rng = np.random.default_rng(0)
    for attempt in range(6):  # a stretched pose (a singular J) can stall: retry from nearby ones
        start = q0 if attempt == 0 else _integrate(model, q0, rng.normal(scale=0.3, size=model.nv), 1.0)
        q1, err = close_loops(model, C, m, start, np.ones(model.nv), 1e-10, 30)
        if err <= 1e-10:
            break
    return constraint_jacobian(model, q1), err


def _integrate(model, q, v, dt):
    """The configuration reached from q along the constant velocity v after dt (a new array; the core's)."""
    out = np.empty(model.nq)
    _core.integrate(model.core, np.ascontiguousarray(q, float), np.ascontiguousarray(v, float), float(dt), out)
    return out


def coupling_rows(C, m, nv):
    """Phi_q of a set of couplings only (constant): e_follower - multiplier e_leader per row."""
    J = np.zeros((m, nv))
    for c in range(C.kind.shape[0]):
        J[C.row[c], C.idx[c, 1]] += 1.0
        J[C.row[c], C.idx[c, 3]] -= C.coef[c, 0]
    return J


def close_loops(model, C, m, q, free, tol, max_iter):
    """Gauss-Newton on phi from q over the coordinates where ``free`` is 1 (see :mod:`dynamics.assemble`):
    returns (q, max |phi(q)|), stopping at tol, after max_iter steps, or where no step reduces |phi|."""
    core, con = model.core, core_constraints(model)
    V = np.zeros((1, model.nv))
    phi, J = np.empty((1, m)), np.empty((1, m, model.nv))
    _core.constraint_terms_batch(core, con, q[None], V, 0, phi, 1, np.inf)
    err = np.abs(phi[0]).max()
    for _ in range(max_iter):
        if err <= tol:
            break
        _core.constraint_terms_batch(core, con, q[None], V, 1, J, 1, np.inf)
        dq = -np.linalg.lstsq(J[0] * free, phi[0], rcond=1e-12)[0] * free
        step = 1.0
        while step > 1e-6:
            q_new = _integrate(model, q, dq, step)
            _core.constraint_terms_batch(core, con, q_new[None], V, 0, phi, 1, np.inf)
            if np.abs(phi[0]).max() < err:
                break
            step *= 0.5
        else:
            break  # no step reduces |phi|: a least-squares minimum with phi != 0
        q, err = q_new, np.abs(phi[0]).max()
    return q, err


# -- what can never hold, what repeats ------------------------------------------------------------------------

def _label(c, con):
    """How a message names constraint c: its kind and name, or its kind, index and the two frames or joints."""
    if con.name:
        return f"{type(con).__name__} {con.name!r}"
    ends = (con.follower, con.leader) if isinstance(con, JointCoupling) else (con.frame_a, con.frame_b)
    return f"{type(con).__name__} {c} ({ends[0]!r}, {ends[1]!r})"


def _joint_origin(model, b):
    return "the world origin" if b < 0 else f"joint {model.joint_names[b]!r}"


def _joint_reach(model, i):
    """(shortest, longest) distance from the origin of body i's parent to body i's origin (its joint's), over the
    joint's range; None when it has no bound (a free or planar joint, a prismatic joint without both limits)."""
    x = np.array(model.tree.Xpos[i])
    S = model.tree.S[model.v_index[i]:model.v_index[i] + model.nv_joint[i]]
    if not np.any(S[:, 3:]):  # a hinge or a ball turns about its origin (S has no linear part): it stays put
        return float(np.linalg.norm(x)), float(np.linalg.norm(x))
    if S.shape[0] != 1:  # a free or planar joint's translations have no limits
        return None
    lo, hi = float(model.lower[model.v_index[i]]), float(model.upper[model.v_index[i]])
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return None
    d = model.tree.Xrot[i] @ model.tree.axis[i]  # the slide direction in the parent's frame
    t = min(max(-float(x @ d), lo), hi)  # the slide's point nearest the parent's origin
    return float(np.linalg.norm(x + t * d)), max(float(np.linalg.norm(x + lo * d)), float(np.linalg.norm(x + hi * d)))


def _segments(model, C, c, con):
    """The segments from anchor a's origin to anchor b's along the tree (through the joint origins up to the
    bodies' common ancestor, or the world): [(shortest, longest, where)], each rigid or bounded by its joint's
    range; None when one of them has no bound."""
    ends = ((int(C.body[c, 0]), C.p[c, 0], con.frame_a), (int(C.body[c, 1]), C.p[c, 1], con.frame_b))
    up = []
    for b, _, _ in ends:
        up.append([b])
        while up[-1][-1] >= 0:
            up[-1].append(int(model.parents[up[-1][-1]]))
    on_b = set(up[1])
    common = next(b for b in up[0] if b in on_b)  # -1 (the world) at the latest
    out = []
    for b, p, frame in ends:
        n = float(np.linalg.norm(p))
        out.append((n, n, f"from the anchor on {frame!r} to {_joint_origin(model, b)}"))
        while b != common:
            reach = _joint_reach(model, b)
            if reach is None:
                return None
            parent = int(model.parents[b])
            out.append((*reach, f"from {_joint_origin(model, parent)} to {_joint_origin(model, b)}"))
            b = parent
    return out


def refuse_never_holding(model, constraints, C):
    """InputError naming a constraint that can hold in no configuration (so never at load, nor in a simulation):

    * a loop whose anchors are both fixed to one rigid body (it constrains nothing, or contradicts itself);
    * a loop whose anchors can never meet: along the tree, the anchor origins are joined by segments whose
      lengths the joints cannot change (a hinge turns about its own origin) or change within a prismatic
      joint's limits; the segments close into a polygon only if none is longer than all the others together;
    * couplings in a cycle (j1 follows j2 follows j1): each joint would follow itself.
    """
    for c, con in enumerate(constraints):
        if C.kind[c] == COUPLING:
            continue
        if C.body[c, 0] == C.body[c, 1]:
            b = int(C.body[c, 0])
            raise InputError(f"{_label(c, con)}: both anchors are fixed to body "
                             f"{'the world' if b < 0 else repr(model.body_names[b])} (frames {con.frame_a!r} and "
                             f"{con.frame_b!r} move as one rigid body), so it constrains nothing, or can never hold; "
                             f"anchor it between bodies that move relative to each other")
        segments = _segments(model, C, c, con)
        total = sum(hi for _, hi, _ in segments or ())
        for lo, hi, where in segments or ():
            if lo > total - hi + 1e-9 * (1.0 + total):
                raise InputError(f"{_label(c, con)}: cannot close in any configuration: the segment of {lo:.3g} m "
                                 f"{where} is longer than the {total - hi:.3g} m of the rest of the chain between "
                                 f"the anchors, so they stay at least {lo - total + hi:.3g} m apart; check the "
                                 f"anchors' positions")
    _refuse_cycles(constraints)


def _refuse_cycles(constraints):
    """InputError when the couplings' follower -> leader links form a cycle (depth first, as a path of names)."""
    leaders = {}
    for con in constraints:
        if isinstance(con, JointCoupling):
            leaders.setdefault(con.follower, []).append(con.leader)
    state = {}  # 1: on the current path, 2: done

    def visit(path):
        state[path[-1]] = 1
        for leader in leaders.get(path[-1], ()):
            if state.get(leader) == 1:
                cycle = path[path.index(leader):] + [leader]
                raise InputError(f"JointCoupling: the couplings form a cycle: {' follows '.join(cycle)}, so each "
                                 f"joint would follow itself; remove one of them")
            if leader not in state:
                visit(path + [leader])
        state[path[-1]] = 2

    for follower in list(leaders):
        if follower not in state:
            visit([follower])


def _coupling_range_notes(model, first):
    """Warnings about the couplings from ``model.constraints[first]`` on that hold nowhere within both joints'
    limits (legal: the limits are not enforced unless simulate's limits="spring"; but the URDF says the joints
    never go there)."""
    notes = []
    for c, con in enumerate(model.constraints):
        if c < first or not isinstance(con, JointCoupling):
            continue
        (lo_f, hi_f), (lo_l, hi_l) = ((float(model.lower[model.v_slice(j).start]),
                                       float(model.upper[model.v_slice(j).start])) for j in (con.follower, con.leader))
        a, b = sorted((con.multiplier * lo_l + con.offset, con.multiplier * hi_l + con.offset))
        if np.isfinite([lo_f, hi_f, lo_l, hi_l]).all() and (b < lo_f - 1e-12 or a > hi_f + 1e-12):
            notes.append(f"{_label(c, con)}: {con.follower} = {con.multiplier:g} {con.leader} + {con.offset:g} spans "
                         f"[{a:g}, {b:g}] over {con.leader}'s limits [{lo_l:g}, {hi_l:g}], outside {con.follower}'s "
                         f"[{lo_f:g}, {hi_f:g}]: it holds nowhere within the limits; check the multiplier and offset")
    return notes


def _assembly_notes(constraints, C, J, tol, err):
    """Warnings about the assembled constraints: loops that do not close near the assembly configuration, and
    constraints whose rows add no rank to those before them (J = Phi_q there, tol its rank tolerance)."""
    notes = []
    if err > 1e-10:
        notes.append(f"constraints: the loops do not close near the assembly configuration: max |phi| = {err:.3g} "
                     f"left by Gauss-Newton from it and 5 nearby starts; start from dynamics.assemble(model, guess) "
                     f"with a guess near a closed pose, or check the anchors")
    repeats, kept, rank = [], J[:0], 0
    for c, con in enumerate(constraints):
        rows = np.vstack([kept, J[C.row[c]:C.row[c] + con.rows]])
        r = int(np.linalg.matrix_rank(rows, tol=tol)) if rows.size else 0
        if r == rank:
            repeats.append(repr(con.name) if con.name else _label(c, con))
        else:
            kept, rank = rows, r
    if repeats:
        shown = ", ".join(repeats[:8]) + (", ..." if len(repeats) > 8 else "")
        notes.append(f"constraints: {len(repeats)} constraint{'s add' if len(repeats) > 1 else ' adds'} no "
                     f"independent rows to those before them: {shown}; the multipliers are then not unique (the "
                     f"dynamics take the minimum-norm ones) and, where the repeats disagree, the loops cannot all "
                     f"close; remove the repeats")
    return notes


# -- kernels -----------------------------------------------------------------------------------------------------

# -- public entry points (the core's constraint_terms_batch) ---------------------------------------------------


def _terms(model, q, v, what):
    checks.check_model(model)
    C, m = arrays(model)
    if v is None:
        Q, batched = checks.configurations(model, q)
        V, B = np.zeros((1, model.nv)), Q.shape[0]
    else:
        Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = np.empty((B, m, model.nv) if what == 1 else (B, m))
    run_core(_core.constraint_terms_batch, model, Q, V, what, out=out)
    return out if batched else out[0]


def constraint_residual(model, q):
    """phi(q): (m,) or (B, m), zero when every loop is closed and every coupling holds (module docstring for
    the rows; metres, radians, or a joint's units for couplings)."""
    return _terms(model, q, None, 0)


def constraint_jacobian(model, q):
    """Phi_q: (m, nv) or (B, m, nv), the constraints' velocity rows (module docstring), world axes."""
    return _terms(model, q, None, 1)


def constraint_bias(model, q, v):
    """Phi_q_dot v: (m,) or (B, m), so that d/dt (Phi_q v) = Phi_q a + Phi_q_dot v."""
    return _terms(model, q, v, 2)


# -- a simulation on or off the constraints ----------------------------------------------------------------------

def warn_off_manifold(model, q0, warnings):
    """Append to ``warnings`` (a simulation report's) when q0 is off the constraints by more than
    :data:`MANIFOLD_TOL`: the first steps would pull it onto them (Baumgarte's terms) with forces of that size,
    or never, and the motion is not the mechanism's."""
    if not model.constraints:
        return
    C, _ = arrays(model)
    if np.all(C.kind == COUPLING):  # one row each, in numpy: no kinematics needed for a gripper
        phi = np.abs(q0[C.idx[:, 0]] - C.coef[:, 0] * q0[C.idx[:, 2]] - C.coef[:, 1])
    else:
        phi = np.abs(constraint_residual(model, q0))
    r = int(np.argmax(phi))
    if phi[r] > MANIFOLD_TOL:
        c = int(np.searchsorted(C.row, r, side="right")) - 1
        warnings.append(f"q0: off the constraints: max |phi(q0)| = {phi[r]:.4g} > {MANIFOLD_TOL:g} (at "
                        f"{_label(c, model.constraints[c])}); the motion starts from a mechanism that is not "
                        f"assembled: start from dynamics.assemble(model, q0), or pass project=True")


def warn_drift(drift, warnings):
    """Append to ``warnings`` when a simulation's constraint drift (position, velocity) went past
    :data:`MANIFOLD_TOL`: its status alone would say "ok" about a mechanism whose loops opened."""
    position, velocity = drift
    if position > MANIFOLD_TOL:
        warnings.append(f"constraint_drift: the constraints opened by up to {position:.3g} > {MANIFOLD_TOL:g} (m, "
                        f"rad or a coupled joint's units; velocity rows up to {velocity:.3g}) during the run: "
                        f"tighten rtol and atol, keep Baumgarte's terms (baumgarte=None), or pass project=True")
