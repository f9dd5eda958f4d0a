"""Narrow phase: the contacts of every candidate pair of a :class:`~dynamics.contact.scene.Scene` at one
configuration, compiled and allocation-free.

Given the world pose (oR_i, op_i) of each body (:func:`_body_world_poses`), geometry g of body b sits at

    oR_g = oR_b R_g,    op_g = oR_b p_g + op_b        (R_g, p_g as stored for body -1: already in the world).

:func:`find_contacts` and :func:`scene_poses` run on the C++ core (core/contact/narrow_phase.cpp, a port of the
kernels below that keeps their order of operations: the same contacts, bit for bit; tests/test_narrow_phase_core.py);
the simulation still calls the numba kernels here until it moves to the core.

For each pair (a, b) (ordered so that kind[a] <= kind[b]), :func:`_collide` first runs the broad phase --
bounding spheres |op_a - op_b| < r_a + r_b, and for a plane (half-space n . x <= h) the test n . op_a - h <
r_a -- then the pair's function from the table below, which writes each penetrating contact into a
:class:`ContactBuffer`:

* ``point``: the world point midway between the two surfaces (the deepest point of each),
* ``normal``: the world unit normal pointing from geometry b towards geometry a (the direction that pushes a
  out of b),
* ``depth``: the penetration along it, > 0 (touching or separated pairs write nothing).

=================  ==========================================================================  ========
pair               method                                                                      contacts
=================  ==========================================================================  ========
sphere - plane     centre's signed distance minus r (a point is a sphere of radius 0)          1
capsule - plane    its two end spheres                                                         2
cylinder - plane   the deepest rim point of each cap and two more on the lower cap at +-120 deg  4
box - plane        each of the 8 vertices below the plane                                      8
sphere - sphere    centres' distance                                                           1
sphere - capsule   sphere against the closest point of the segment                             1
capsule - capsule  closest points of the segments; parallel overlapping segments: both ends     2
                   of the overlap
sphere - box       closest point of the box (inside: the nearest face)                         1
capsule - box      both end spheres when both penetrate, else the deepest point of the         2
                   segment (golden-section search of the box's signed distance, convex)
box - box          separating axis test over 15 axes; a face axis: the incident face clipped   8
                   against the reference face's sides (Sutherland-Hodgman), its points below
                   the reference face; an edge-edge axis: the closest points of the two edges
=================  ==========================================================================  ========

Once a capsule's axis enters a box the depth is that of the axis's deepest point (plus r), not the least
translation out.  A cylinder against a sphere, capsule or box is the capsule of the same radius and length
(its flat ends rounded: contact starts up to r early beyond each end); against a plane it is exact.
"""

from typing import NamedTuple

import numpy as np

from .. import _core, checks
from .._numba import borrow, helper, inline_kernel, kernel
from ..errors import InputError
from ..kinematics import _world_pose
from ..spatial import add, cross, dot, load3, load33, matmul, rot, rotT, scale
from .scene import BOX, CAPSULE, CYLINDER, PLANE, POINT

#: separating-axis test: an edge-edge axis is taken only when its overlap is below this fraction of the best
#: face axis's (faces give a manifold; edges, nearly parallel to a face, a single point)
EDGE_BIAS = 0.95
#: the golden-section search of capsule-box runs this many steps (0.618^60 of the length: round-off)
GOLDEN_STEPS = 60


class ContactBuffer(NamedTuple):
    """Preallocated contact outputs (K = ``scene.max_contacts``); :func:`_collide` fills the first n.
    ``work`` is the narrow phase's scratch (box-box clipping)."""

    pair: np.ndarray  # (K,) int64: index of the pair in scene.pair_a / pair_b
    point: np.ndarray  # (K, 3) world contact point, midway between the surfaces
    normal: np.ndarray  # (K, 3) world unit normal, from geometry b towards geometry a
    depth: np.ndarray  # (K,) penetration > 0
    work: np.ndarray  # (2, 8, 3) scratch


def contact_buffer(scene) -> ContactBuffer:
    """A :class:`ContactBuffer` with room for every contact ``scene`` can produce at once."""
    K = int(scene.max_contacts)
    return ContactBuffer(np.zeros(K, np.int64), np.zeros((K, 3)), np.zeros((K, 3)), np.zeros(K),
                         np.zeros((2, 8, 3)))


@inline_kernel
def _body_world_poses(tree, q, oR, op):
    """oR[i], op[i] = world rotation and position of every body i at q (:mod:`dynamics.kinematics`)."""
    for i in range(tree.parents.shape[0]):
        _world_pose(tree, i, q, oR, op)


# -- small vector algebra ----------------------------------------------------------------------------

@helper
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@helper
def column(R, j):
    return (R[j], R[3 + j], R[6 + j])


@helper
def clamp(x, lo, hi):
    return lo if x < lo else (hi if x > hi else x)


@helper
def unit(x, fallback):
    """x / |x|, or ``fallback`` when x is (nearly) zero."""
    n = np.sqrt(dot(x, x))
    return scale(1.0 / n, x) if n > 1e-300 else fallback


@helper
def _geometry_pose(S, g, oR, op):
    """World (R, p) of geometry g."""
    R, p = load33(S.R, g), load3(S.p, g)
    b = S.body[g]
    if b < 0:
        return R, p
    Rb = load33(oR, b)
    return matmul(Rb, R), add(rot(Rb, p), load3(op, b))


@helper
def _centre(S, g, oR, op):
    """World position of geometry g's origin (the centre of its bounding sphere)."""
    p = load3(S.p, g)
    b = S.body[g]
    return p if b < 0 else add(rot(load33(oR, b), p), load3(op, b))


@helper
def _emit(out, n, k, on_a, on_b, normal, depth):
    """Write contact n of pair k (midway between the surface points on a and on b); returns the new count."""
    if n >= out.depth.shape[0]:  # a buffer from another scene: never write past it
        return n
    out.pair[n] = k
    for r in range(3):
        out.point[n, r] = 0.5 * (on_a[r] + on_b[r])
        out.normal[n, r] = normal[r]
    out.depth[n] = depth
    return n + 1


# -- broad phase -------------------------------------------------------------------------------------

@helper
def _overlap(S, a, b, oR, op):
    """False when the pair's bounding volumes are apart (b a plane: a's bounding sphere above it)."""
    ca = _centre(S, a, oR, op)
    if S.kind[b] == PLANE:
        R, p = load33(S.R, b), load3(S.p, b)
        nn = column(R, 2)
        return dot(nn, ca) - dot(nn, p) < S.radius[a]
    d = sub(ca, _centre(S, b, oR, op))
    r = S.radius[a] + S.radius[b]
    return dot(d, d) < r * r


@helper
def _separation(S, a, b, oR, op):
    """How far apart the pair's bounding volumes are, the quantity :func:`_overlap` compares with zero (its
    square root for two spheres): negative when they overlap (:mod:`.clearance`)."""
    ca = _centre(S, a, oR, op)
    if S.kind[b] == PLANE:
        nn = column(load33(S.R, b), 2)
        return dot(nn, ca) - dot(nn, load3(S.p, b)) - S.radius[a]
    d = sub(ca, _centre(S, b, oR, op))
    return np.sqrt(dot(d, d)) - (S.radius[a] + S.radius[b])


@kernel
def _broad_phase(S, oR, op, keep):
    """keep[:m] = the pairs that pass the broad phase; returns m (what the narrow phase then examines)."""
    S, oR, op, keep = borrow(S), borrow(oR), borrow(op), borrow(keep)
    m = 0
    for k in range(S.pair_a.shape[0]):
        if _overlap(S, S.pair_a[k], S.pair_b[k], oR, op):
            keep[m] = k
            m += 1
    return m


# -- against a plane (half-space n . x <= h); the normal is n -----------------------------------------

@helper
def _sphere_plane(out, n, k, c, r, nn, h):
    s = dot(nn, c) - h  # the centre's height above the plane
    if s >= r:
        return n
    return _emit(out, n, k, sub(c, scale(r, nn)), sub(c, scale(s, nn)), nn, r - s)


@helper
def _capsule_plane(out, n, k, c, u, half, r, nn, h):
    n = _sphere_plane(out, n, k, sub(c, scale(half, u)), r, nn, h)
    return _sphere_plane(out, n, k, add(c, scale(half, u)), r, nn, h)


@helper
def _box_plane(out, n, k, c, R, e, nn, h):
    for i in range(8):
        x = ((e[0] if i & 1 else -e[0]), (e[1] if i & 2 else -e[1]), (e[2] if i & 4 else -e[2]))
        n = _sphere_plane(out, n, k, add(c, rot(R, x)), 0.0, nn, h)
    return n


@helper
def _cylinder_plane(out, n, k, c, u, half, r, nn, h):
    """Each cap's deepest rim point, and on the lower cap two more at +-120 degrees (a tripod when flat)."""
    w = sub(scale(dot(nn, u), u), nn)  # -n projected on the caps' plane: towards the deepest rim point
    t = (1.0, 0.0, 0.0) if abs(u[0]) < 0.9 else (0.0, 1.0, 0.0)
    w = unit(w, unit(cross(u, t), (0.0, 0.0, 1.0)))
    v = cross(u, w)
    lower = -1.0 if dot(nn, u) > 0 else 1.0  # the cap on this side of the centre is the lower one
    for side in (lower, -lower):
        cc = add(c, scale(side * half, u))
        n = _sphere_plane(out, n, k, add(cc, scale(r, w)), 0.0, nn, h)
        if side == lower:
            for s in (0.8660254037844386, -0.8660254037844386):
                x = add(scale(-0.5 * r, w), scale(s * r, v))
                n = _sphere_plane(out, n, k, add(cc, x), 0.0, nn, h)
    return n


# -- spheres and segments ----------------------------------------------------------------------------

@helper
def _sphere_sphere(out, n, k, ca, ra, cb, rb):
    return _balls(out, n, k, ca, ra, cb, rb, (0.0, 0.0, 1.0))


@helper
def _balls(out, n, k, ca, ra, cb, rb, fallback):
    """Two balls; ``fallback``: the unit normal when their centres coincide (any direction is as good for two
    spheres, not for two capsules whose axes meet: there it must be across the axes)."""
    d = sub(ca, cb)
    dist = np.sqrt(dot(d, d))
    if dist >= ra + rb:
        return n
    nn = scale(1.0 / dist, d) if dist > 1e-12 * (ra + rb) else fallback
    return _emit(out, n, k, sub(ca, scale(ra, nn)), add(cb, scale(rb, nn)), nn, ra + rb - dist)


@helper
def _across(u1, u2):
    """A unit vector perpendicular to both unit axes (their common normal), or to u1 alone when they are
    parallel: the direction that separates two capsules whose axes meet."""
    w = cross(u1, u2)
    if dot(w, w) > 1e-12:
        return scale(1.0 / np.sqrt(dot(w, w)), w)
    a = (1.0, 0.0, 0.0) if abs(u1[0]) < 0.6 else (0.0, 1.0, 0.0)
    w = sub(a, scale(dot(a, u1), u1))
    return scale(1.0 / np.sqrt(dot(w, w)), w)


@helper
def _segment_point(c, u, half, x):
    """The point of the segment c + t u, |t| <= half, closest to x."""
    return add(c, scale(clamp(dot(sub(x, c), u), -half, half), u))


@helper
def _segments(c1, u1, h1, c2, u2, h2):
    """(s, t) of the closest points c1 + s u1, c2 + t u2 of two segments (unit u; Ericson 2005, sec. 5.1.9)."""
    r = sub(c1, c2)
    b, c, f = dot(u1, u2), dot(u1, r), dot(u2, r)
    denom = 1.0 - b * b
    if denom > 1e-12:
        s = clamp((b * f - c) / denom, -h1, h1)
    else:  # parallel: the point of segment 1 nearest to segment 2's centre
        s = clamp(-c, -h1, h1)
    t = b * s + f
    if t < -h2 or t > h2:
        t = clamp(t, -h2, h2)
        s = clamp(b * t - c, -h1, h1)
    return s, t


@helper
def _capsule_capsule(out, n, k, c1, u1, h1, r1, c2, u2, h2, r2):
    """Closest points of the axes; parallel axes that overlap along their length: both ends of the overlap."""
    b = dot(u1, u2)
    if 1.0 - b * b <= 1e-12:
        m = -dot(u1, sub(c1, c2))  # segment 2's centre along axis 1
        lo, hi = max(-h1, m - h2), min(h1, m + h2)
        if lo < hi:
            for s in (lo, hi):
                x = add(c1, scale(s, u1))
                n = _balls(out, n, k, x, r1, _segment_point(c2, u2, h2, x), r2, _across(u1, u2))
            return n
    s, t = _segments(c1, u1, h1, c2, u2, h2)
    return _balls(out, n, k, add(c1, scale(s, u1)), r1, add(c2, scale(t, u2)), r2, _across(u1, u2))


# -- boxes ---------------------------------------------------------------------------------------------

@helper
def _box_distance(cb, Rb, e, x):
    """Signed distance of point x to the box (negative inside)."""
    y = rotT(Rb, sub(x, cb))
    q = (abs(y[0]) - e[0], abs(y[1]) - e[1], abs(y[2]) - e[2])
    o = (max(q[0], 0.0), max(q[1], 0.0), max(q[2], 0.0))
    return np.sqrt(dot(o, o)) + min(max(q[0], max(q[1], q[2])), 0.0)


@helper
def _sphere_box(out, n, k, c, r, cb, Rb, e):
    """Sphere a against box b: the box's closest point, or from inside the nearest face."""
    y = rotT(Rb, sub(c, cb))
    z = (clamp(y[0], -e[0], e[0]), clamp(y[1], -e[1], e[1]), clamp(y[2], -e[2], e[2]))
    d = sub(y, z)
    dist = np.sqrt(dot(d, d))
    if dist > 0.0:  # centre outside the box
        if dist >= r:
            return n
        nn = rot(Rb, scale(1.0 / dist, d))
        return _emit(out, n, k, sub(c, scale(r, nn)), add(cb, rot(Rb, z)), nn, r - dist)
    i, gap = 0, e[0] - abs(y[0])  # inside: leave through the nearest face
    for j in (1, 2):
        if e[j] - abs(y[j]) < gap:
            i, gap = j, e[j] - abs(y[j])
    sgn = 1.0 if y[i] >= 0.0 else -1.0
    nn = scale(sgn, column(Rb, i))
    on_b = add(c, scale(gap, nn))
    return _emit(out, n, k, sub(c, scale(r, nn)), on_b, nn, r + gap)


@helper
def _capsule_box(out, n, k, c, u, half, r, cb, Rb, e):
    """Both end spheres when both penetrate (a capsule lying on a face), else the segment's deepest point."""
    p0, p1 = sub(c, scale(half, u)), add(c, scale(half, u))
    if _box_distance(cb, Rb, e, p0) < r and _box_distance(cb, Rb, e, p1) < r:
        n = _sphere_box(out, n, k, p0, r, cb, Rb, e)
        return _sphere_box(out, n, k, p1, r, cb, Rb, e)
    lo, hi = -half, half  # golden-section search: the signed distance along the segment is convex
    g = 0.6180339887498949
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1 = _box_distance(cb, Rb, e, add(c, scale(x1, u)))
    f2 = _box_distance(cb, Rb, e, add(c, scale(x2, u)))
    for _ in range(GOLDEN_STEPS):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = _box_distance(cb, Rb, e, add(c, scale(x1, u)))
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = _box_distance(cb, Rb, e, add(c, scale(x2, u)))
    return _sphere_box(out, n, k, add(c, scale(0.5 * (lo + hi), u)), r, cb, Rb, e)


@helper
def _box_overlap(L, d, RA, ea, RB, eb):
    """Overlap of the two boxes' projections on the unit axis L (negative: L separates them)."""
    ra = ea[0] * abs(dot(column(RA, 0), L)) + ea[1] * abs(dot(column(RA, 1), L)) + ea[2] * abs(dot(column(RA, 2), L))
    rb = eb[0] * abs(dot(column(RB, 0), L)) + eb[1] * abs(dot(column(RB, 1), L)) + eb[2] * abs(dot(column(RB, 2), L))
    return ra + rb - abs(dot(d, L))


@helper
def _box_box(out, n, k, ca, RA, ea, cb, RB, eb):
    """Separating axis test over the 6 face normals and 9 edge crossings; the axis of least overlap gives a
    face manifold (:func:`_box_face`) or one edge-edge point (:func:`_box_edges`)."""
    d = sub(ca, cb)
    best, axis, code = np.inf, (0.0, 0.0, 1.0), -1
    for i in range(6):
        L = column(RA, i) if i < 3 else column(RB, i - 3)
        o = _box_overlap(L, d, RA, ea, RB, eb)
        if o < 0.0:
            return n
        if o < best:
            best, axis, code = o, L, i
    face = best
    for i in range(3):
        for j in range(3):
            L = cross(column(RA, i), column(RB, j))
            ln = np.sqrt(dot(L, L))
            if ln < 1e-6:  # (nearly) parallel edges: a face axis covers them
                continue
            L = scale(1.0 / ln, L)
            o = _box_overlap(L, d, RA, ea, RB, eb)
            if o < 0.0:
                return n
            if o < EDGE_BIAS * face and o < best:
                best, axis, code = o, L, 6 + 3 * i + j
    if dot(d, axis) < 0.0:
        axis = scale(-1.0, axis)  # from b towards a
    if code < 3:  # a face of A is the reference: its outward normal towards B is -axis
        return _box_face(out, n, k, ca, RA, ea, code, scale(-1.0, axis), cb, RB, eb, True)
    if code < 6:
        return _box_face(out, n, k, cb, RB, eb, code - 3, axis, ca, RA, ea, False)
    return _box_edges(out, n, k, ca, RA, ea, (code - 6) // 3, cb, RB, eb, (code - 6) % 3, axis)


@helper
def _box_face(out, n, k, cr, Rr, er, i, N, ci, Ri, ei, ref_is_a):
    """Reference face i of box r (outward normal N, towards the other box), the incident box's face most
    opposed to N clipped by the reference face's four side planes (Sutherland-Hodgman); each clipped point below
    the reference face is a contact."""
    work = out.work
    j, big = 0, -1.0  # the incident face: its normal most anti-parallel to N
    for m in range(3):
        if abs(dot(column(Ri, m), N)) > big:
            j, big = m, abs(dot(column(Ri, m), N))
    nj = column(Ri, j)
    ic = add(ci, scale(-ei[j] if dot(nj, N) > 0.0 else ei[j], nj))
    s1, s2 = scale(ei[(j + 1) % 3], column(Ri, (j + 1) % 3)), scale(ei[(j + 2) % 3], column(Ri, (j + 2) % 3))
    for v in range(4):
        x = add(ic, add(scale(1.0 if v == 0 or v == 3 else -1.0, s1), scale(1.0 if v < 2 else -1.0, s2)))
        for r in range(3):
            work[0, v, r] = x[r]
    m = 4
    for side in range(4):  # the planes t . (x - cr) <= e along the reference face's two tangents, both ways
        ax = (i + 1 + side // 2) % 3
        t = scale(1.0 if side % 2 == 0 else -1.0, column(Rr, ax))
        m = _clip(work, side % 2, m, t, dot(t, cr) + er[ax])
    fc = add(cr, scale(er[i], N))
    for v in range(m):
        x = (work[0, v, 0], work[0, v, 1], work[0, v, 2])
        sep = dot(sub(x, fc), N)
        if sep < 0.0:
            on_ref = sub(x, scale(sep, N))
            if ref_is_a:
                n = _emit(out, n, k, on_ref, x, scale(-1.0, N), -sep)
            else:
                n = _emit(out, n, k, x, on_ref, N, -sep)
    return n


@helper
def _clip(work, src, m, t, h):
    """Clip the polygon work[src, :m] by the half-space t . x <= h into work[1 - src]; returns its size (one
    more at most).  After an even number of clips the polygon is back in work[0]."""
    dst, out = 1 - src, 0
    for v in range(m):
        P = (work[src, v - 1 if v > 0 else m - 1, 0], work[src, v - 1 if v > 0 else m - 1, 1],
             work[src, v - 1 if v > 0 else m - 1, 2])
        Q = (work[src, v, 0], work[src, v, 1], work[src, v, 2])
        fp, fq = dot(t, P) - h, dot(t, Q) - h
        if (fp <= 0.0) != (fq <= 0.0) and out < 8:  # the edge crosses the plane
            x = add(P, scale(fp / (fp - fq), sub(Q, P)))
            for r in range(3):
                work[dst, out, r] = x[r]
            out += 1
        if fq <= 0.0 and out < 8:
            for r in range(3):
                work[dst, out, r] = Q[r]
            out += 1
    return out


@helper
def _box_edges(out, n, k, ca, RA, ea, i, cb, RB, eb, j, L):
    """Edge i of A against edge j of B along the axis L (from B towards A): the edges that support each box
    towards the other, and their closest points."""
    pa, pb = ca, cb
    for m in range(3):
        if m != i:
            a = column(RA, m)
            pa = add(pa, scale(-ea[m] if dot(a, L) > 0.0 else ea[m], a))
        if m != j:
            b = column(RB, m)
            pb = add(pb, scale(eb[m] if dot(b, L) > 0.0 else -eb[m], b))
    ua, ub = column(RA, i), column(RB, j)
    s, t = _segments(pa, ua, ea[i], pb, ub, eb[j])
    qa, qb = add(pa, scale(s, ua)), add(pb, scale(t, ub))
    depth = dot(sub(qb, qa), L)
    if depth <= 0.0:
        return n
    return _emit(out, n, k, qa, qb, L, depth)


# -- the table -----------------------------------------------------------------------------------------

@helper
def _pair(S, k, a, b, oR, op, out, n):
    """The contacts of pair k (kind[a] <= kind[b]), written from out[n]; returns the new count."""
    ka, kb = S.kind[a], S.kind[b]
    Ra, ca = _geometry_pose(S, a, oR, op)
    Rb, cb = _geometry_pose(S, b, oR, op)
    sa, sb = load3(S.size, a), load3(S.size, b)
    ua, ub = column(Ra, 2), column(Rb, 2)
    if kb == PLANE:
        h = dot(ub, cb)
        if ka <= POINT:
            return _sphere_plane(out, n, k, ca, sa[0], ub, h)
        if ka == CAPSULE:
            return _capsule_plane(out, n, k, ca, ua, 0.5 * sa[1], sa[0], ub, h)
        if ka == CYLINDER:
            return _cylinder_plane(out, n, k, ca, ua, 0.5 * sa[1], sa[0], ub, h)
        return _box_plane(out, n, k, ca, Ra, scale(0.5, sa), ub, h)
    if kb == BOX:
        eb = scale(0.5, sb)
        if ka <= POINT:
            return _sphere_box(out, n, k, ca, sa[0], cb, Rb, eb)
        if ka <= CYLINDER:
            return _capsule_box(out, n, k, ca, ua, 0.5 * sa[1], sa[0], cb, Rb, eb)
        return _box_box(out, n, k, ca, Ra, scale(0.5, sa), cb, Rb, eb)
    if kb >= CAPSULE:  # a capsule or cylinder (as a capsule)
        if ka <= POINT:
            return _sphere_sphere(out, n, k, ca, sa[0], _segment_point(cb, ub, 0.5 * sb[1], ca), sb[0])
        return _capsule_capsule(out, n, k, ca, ua, 0.5 * sa[1], sa[0], cb, ub, 0.5 * sb[1], sb[0])
    return _sphere_sphere(out, n, k, ca, sa[0], cb, sb[0])


@kernel
def _collide(S, oR, op, out):
    """Write the penetrating contacts of every candidate pair of S (``scene.arrays``) at the bodies' world
    poses (oR (nb, 3, 3), op (nb, 3)) into out (a :class:`ContactBuffer`); returns their number."""
    # views with no owner (dynamics._numba.borrow): passing the 13 arrays down to each pair's function would
    # otherwise cost two atomic reference counts per array per call, most of the time of a contact
    S, oR, op, out = borrow(S), borrow(oR), borrow(op), borrow(out)
    n = 0
    for k in range(S.pair_a.shape[0]):
        a, b = S.pair_a[k], S.pair_b[k]
        if _overlap(S, a, b, oR, op):
            n = _pair(S, k, a, b, oR, op, out, n)
    return n


# -- from Python -----------------------------------------------------------------------------------------

class Contacts(NamedTuple):
    """The penetrating contacts of a scene at one configuration (n of them), from :func:`find_contacts`."""

    a: tuple  # (n,) name of geometry a of each contact (scene.names)
    b: tuple  # (n,) name of geometry b (the normal points from b towards a)
    pair: np.ndarray  # (n,) index of the pair in scene.pair_a / pair_b
    point: np.ndarray  # (n, 3) world point midway between the surfaces
    normal: np.ndarray  # (n, 3) world unit normal from b towards a
    depth: np.ndarray  # (n,) penetration (m), > 0


def _checked_configuration(model, scene, q):
    """q checked against ``model`` and ``scene`` against its bodies: the one configuration, a float64 copy."""
    Q, batched = checks.configurations(model, q)
    if batched:
        raise InputError(f"q: expected one configuration of shape ({model.nq},), got {np.shape(q)}")
    if scene.body.shape[0] and int(scene.body.max()) >= model.nbodies:
        raise InputError(f"scene: built for a model with more bodies than {model.name!r} has ({model.nbodies})")
    return np.ascontiguousarray(Q[0], dtype=np.float64).copy()


def _world_arrays(model, scene, q):
    """q checked, and the bodies' world rotations and positions at it (numba's kinematics: what the compiled
    narrow phase :func:`_collide` takes)."""
    q = _checked_configuration(model, scene, q)
    oR, op = np.empty((model.nbodies, 3, 3)), np.empty((model.nbodies, 3))
    _body_world_poses(model.tree, q, oR, op)
    return oR, op


def scene_poses(model, scene, q) -> np.ndarray:
    """(ng, 4, 4) world pose of every geometry of ``scene`` at ``q`` (to draw it; a plane's z axis is its
    normal and its origin the point of the plane nearest the world origin)."""
    q = _checked_configuration(model, scene, q)
    return _core.scene_poses(model.core, scene.body, scene.R, scene.p, q)


def find_contacts(model, scene, q) -> Contacts:
    """The contacts of ``scene`` (built for ``model`` by :func:`~dynamics.contact.scene.build_scene`) at the
    configuration ``q``: the broad and narrow phase of the C++ core (core/contact/narrow_phase.cpp, the same
    contacts, bit for bit, as the compiled :func:`_collide` the simulation runs each step)."""
    q = _checked_configuration(model, scene, q)
    k, point, normal, depth = _core.find_contacts(model.core, *scene.arrays, q, scene.max_contacts)
    return Contacts(tuple(scene.names[scene.pair_a[i]] for i in k), tuple(scene.names[scene.pair_b[i]] for i in k),
                    k, point, normal, depth)
