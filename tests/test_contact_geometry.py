"""Narrow phase of contact (dynamics.contact.narrow_phase) against closed forms and an independent reference.

Every pair is run through the real path: geometry declared on two free bodies "A" and "B" of one model, a
Scene from build_scene, the bodies' world poses set directly, and the core's narrow phase (_core.collide_at).  The
contacts are returned with the normal pointing from the second geometry towards the first, whatever order the scene
keeps the pair in.  Closed forms: distances of spheres, segments and boxes placed at known poses (rotated and
translated), box manifolds by their area.  Random placements are checked against numpy references written
here: segment distances by bounded minimisation, box penetration as the minimum over directions of the
support functions h_A(-d) + h_B(d), and every contact point lying in both solids.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

import dynamics
from dynamics import Box, Capsule, ContactPoint, Cylinder, Ground, HalfSpace, Sphere
from dynamics import _core
from dynamics.contact.narrow_phase import EDGE_BIAS
from dynamics.contact.scene import build_scene

EMPTY = dynamics.load_urdf('<robot name="w"><link name="world"/></robot>')
MODEL = dynamics.add_free_body(dynamics.add_free_body(EMPTY, "A", Sphere("A", 0.1), 1.0), "B",
                               Sphere("B", 0.1), 1.0)


def pose(R=None, p=(0, 0, 0)):
    T = np.eye(4)
    T[:3, :3] = np.eye(3) if R is None else (R.as_matrix() if isinstance(R, Rotation) else R)
    T[:3, 3] = p
    return T


def collide(ga, Ta, gb, Tb=None):
    """(points, normals from gb towards ga, depths) of geometry ga on body A at world pose Ta and gb: on body B
    at Tb, or a plane of the world."""
    plane = isinstance(gb, (Ground, HalfSpace))
    scene = build_scene(MODEL, [ga] if plane else [ga, gb], world=[gb] if plane else [])
    assert scene.npairs == 1
    Tb = np.eye(4) if Tb is None else Tb
    poses = np.ascontiguousarray([Ta, Tb], dtype=float)
    pair, point, normal, depth = _core.collide_at(MODEL.core, *scene.arrays, poses, scene.max_contacts)
    assert len(depth) <= scene.max_contacts
    sign = 1.0 if scene.pair_a[0] == 0 else -1.0
    return point, sign * normal, depth


def test_sphere_plane_tilted_ground():
    n = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    c = np.array([0.4, 0.1, 0.2])
    h = 0.25
    s = n @ c - h  # centre's height above the plane
    P, N, D = collide(Sphere("A", 0.1), pose(p=c), Ground(normal=(0.3, -0.2, 1.0), height=h))
    assert len(D) == 1
    np.testing.assert_allclose(D, [0.1 - s], rtol=1e-13)
    np.testing.assert_allclose(N[0], n, atol=1e-15)
    np.testing.assert_allclose(P[0], c - (0.1 + s) / 2 * n, atol=1e-15)
    assert len(collide(Sphere("A", 0.1), pose(p=c + 0.2 * n), Ground(normal=(0.3, -0.2, 1.0), height=h))[2]) == 0


def test_point_and_offset_sphere_on_a_rotated_body():
    R = Rotation.from_euler("xyz", [0.3, -0.5, 1.1])
    T = pose(R, (1.0, 2.0, 0.05))
    x = T[:3, :3] @ [0.1, 0.2, -0.3] + T[:3, 3]  # the body point (0.1, 0.2, -0.3) in the world
    P, N, D = collide(ContactPoint("A", (0.1, 0.2, -0.3)), T, Ground())
    np.testing.assert_allclose(D, [-x[2]], rtol=1e-13)
    np.testing.assert_allclose(P[0], x + [0, 0, -x[2] / 2], atol=1e-15)
    P, N, D = collide(Sphere("A", 0.02, offset=(0.1, 0.2, -0.3)), T, Ground())
    np.testing.assert_allclose(D, [0.02 - x[2]], rtol=1e-13)


def test_sphere_sphere_and_symmetry():
    ca, cb = np.array([0.1, 0.2, 0.3]), np.array([0.25, 0.1, 0.35])
    d = np.linalg.norm(ca - cb)
    u = (ca - cb) / d
    P, N, D = collide(Sphere("A", 0.1), pose(p=ca), Sphere("B", 0.12), pose(p=cb))
    np.testing.assert_allclose(D, [0.22 - d], rtol=1e-13)
    np.testing.assert_allclose(N[0], u, atol=1e-15)
    np.testing.assert_allclose(P[0], ((ca - 0.1 * u) + (cb + 0.12 * u)) / 2, atol=1e-15)
    P2, N2, D2 = collide(Sphere("A", 0.12), pose(p=cb), Sphere("B", 0.1), pose(p=ca))  # swapped: flipped normal
    np.testing.assert_allclose(N2, -N, atol=1e-15)
    np.testing.assert_allclose(D2, D, rtol=1e-15)
    np.testing.assert_allclose(P2, P, atol=1e-15)
    assert len(collide(Sphere("A", 0.1), pose(p=ca), Sphere("B", 0.1), pose(p=ca + [0.2001, 0, 0]))[2]) == 0


def test_capsule_capsule_skew():
    """Axes along x (at z = 0) and along y (at z = 0.15), crossing above the origin: depth r1 + r2 - 0.15."""
    Ra, Rb = Rotation.from_euler("y", np.pi / 2), Rotation.from_euler("x", np.pi / 2)  # local z -> x, -> -y
    shift = np.array([0.3, -0.2, 0.1])
    P, N, D = collide(Capsule("A", 0.05, 0.6), pose(Ra, shift + [0.1, 0, 0]),
                      Capsule("B", 0.12, 0.8), pose(Rb, shift + [0, 0.05, 0.15]))
    np.testing.assert_allclose(D, [0.17 - 0.15], rtol=1e-12)
    np.testing.assert_allclose(N[0], [0, 0, -1], atol=1e-15)
    np.testing.assert_allclose(P[0], shift + [0, 0, (0.05 + 0.15 - 0.12) / 2], atol=1e-15)


def test_capsule_capsule_parallel_overlap_gives_both_ends():
    R = Rotation.from_euler("z", 0.4) * Rotation.from_euler("y", np.pi / 2)  # axes along x turned by 0.4 about z
    e = R.as_matrix()[:, 2]
    side = R.as_matrix()[:, 1]
    P, N, D = collide(Capsule("A", 0.05, 1.0), pose(R, 0.09 * side), Capsule("B", 0.05, 0.6), pose(R, 0.3 * e))
    np.testing.assert_allclose(D, [0.01, 0.01], rtol=1e-10)
    np.testing.assert_allclose(N, [side, side], atol=1e-12)
    # the overlap of the two segments along the axis: from 0.0 to 0.5 of A's parameter
    along = sorted(P @ e)
    np.testing.assert_allclose(along, [0.0, 0.5], atol=1e-12)


def test_capsule_and_cylinder_on_the_ground():
    R = Rotation.from_euler("y", 0.3)
    c = np.array([0.2, 0.0, 0.25])
    u = R.as_matrix()[:, 2]
    P, N, D = collide(Capsule("A", 0.1, 0.8), pose(R, c), Ground())
    ends = [c - 0.4 * u, c + 0.4 * u]
    want = sorted(0.1 - e[2] for e in ends if e[2] < 0.1)
    np.testing.assert_allclose(sorted(D), want, rtol=1e-12)
    # an upright cylinder sunk 0.01 rests on three rim points of its lower cap
    P, N, D = collide(Cylinder("A", 0.1, 0.4), pose(p=(0.3, 0.1, 0.19)), Ground())
    np.testing.assert_allclose(D, [0.01] * 3, rtol=1e-10)
    np.testing.assert_allclose(np.hypot(P[:, 0] - 0.3, P[:, 1] - 0.1), [0.1] * 3, rtol=1e-12)
    assert abs(np.mean(P[:, 0]) - 0.3) < 1e-12 and abs(np.mean(P[:, 1]) - 0.1) < 1e-12  # a centred tripod
    # tilted: the deepest rim point of the lower cap is below the centre by l/2 cos + r sin
    t = 0.5
    z = 0.2 * np.cos(t) + 0.1 * np.sin(t) - 0.02
    P, N, D = collide(Cylinder("A", 0.1, 0.4), pose(Rotation.from_euler("x", t), (0, 0, z)), Ground())
    np.testing.assert_allclose(D.max(), 0.02, rtol=1e-12)


def test_box_corner_on_a_plane():
    R = Rotation.from_euler("xyz", [0.4, 0.3, 0.2])
    size = np.array([0.2, 0.3, 0.5])
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * size / 2
    c = np.array([0.0, 0.1, 0.3])
    world = corners @ R.as_matrix().T + c
    n = np.array([0.0, 0.6, 0.8])
    P, N, D = collide(Box("A", size), pose(R, c), HalfSpace(n, 0.1))
    s = world @ n - 0.1
    np.testing.assert_allclose(sorted(D), sorted(-s[s < 0]), rtol=1e-12)
    np.testing.assert_allclose(N, np.tile(n, (len(D), 1)), atol=1e-15)


def test_box_stacked_on_a_box_manifold():
    """A 0.2 m cube turned by 30 degrees sunk 0.01 into a 1 x 1 x 0.2 slab: its four bottom corners, area 0.04;
    hanging half over the slab's edge, the clipped area is the overlap, 0.02."""
    yaw = Rotation.from_euler("z", np.pi / 6)
    for x, area, count in ((0.0, 0.04, 4), (0.5, None, None)):
        P, N, D = collide(Box("A", (0.2, 0.2, 0.2)), pose(yaw, (x, 0.1, 0.1 + 0.1 - 0.01)),
                          Box("B", (1.0, 1.0, 0.2)), pose(p=(0, 0, 0)))
        np.testing.assert_allclose(D, 0.01, rtol=1e-9)
        np.testing.assert_allclose(N, np.tile([0, 0, 1], (len(D), 1)), atol=1e-12)
        np.testing.assert_allclose(P[:, 2], 0.1 - 0.005, atol=1e-12)
        hull = ConvexHull(P[:, :2])
        if area is not None:
            assert len(D) == count
            np.testing.assert_allclose(hull.volume, area, rtol=1e-9)
        else:  # the half of the cube's footprint with x <= 0.5
            np.testing.assert_allclose(hull.volume, 0.02, rtol=1e-9)
            assert np.all(P[:, 0] <= 0.5 + 1e-12)


def test_box_edge_on_edge():
    """Two cubes of side 1 each turned 45 degrees, about x and about y: their edges cross at right angles, the
    top one's lower edge sunk d into the lower one's upper edge."""
    d = 0.01
    h = np.sqrt(0.5)  # half diagonal
    P, N, D = collide(Box("A", (1, 1, 1)), pose(Rotation.from_euler("x", np.pi / 4), (0.0, 0.0, 2 * h - d)),
                      Box("B", (1, 1, 1)), pose(Rotation.from_euler("y", np.pi / 4)))
    np.testing.assert_allclose(D, [d], rtol=1e-9)
    np.testing.assert_allclose(N[0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(P[0], [0, 0, h - d / 2], atol=1e-12)


@pytest.mark.parametrize("where, centre, depth, normal", [
    ("face", (0.0, 0.0, 0.25 + 0.05 - 0.01), 0.01, (0, 0, 1)),
    ("edge", (0.5 + 0.03, 0.0, 0.25 + 0.03), 0.05 - 0.03 * np.sqrt(2), (1 / np.sqrt(2), 0, 1 / np.sqrt(2))),
    ("corner", (0.52, 0.32, 0.27), 0.05 - 0.02 * np.sqrt(3), (1 / np.sqrt(3),) * 3),
    ("inside", (0.45, 0.0, 0.0), 0.05 + 0.05, (1, 0, 0)),
])
def test_sphere_box(where, centre, depth, normal):
    """A box 1 x 0.6 x 0.5 turned and moved; a sphere of radius 0.05 over its face, edge, corner, or inside."""
    R = Rotation.from_euler("xyz", [0.2, -0.7, 0.5])
    t = np.array([0.3, -0.1, 0.8])
    P, N, D = collide(Sphere("A", 0.05), pose(R, R.apply(centre) + t), Box("B", (1.0, 0.6, 0.5)), pose(R, t))
    np.testing.assert_allclose(D, [depth], rtol=1e-12)
    np.testing.assert_allclose(N[0], R.apply(normal), atol=1e-12)


def test_capsule_on_a_box_face_and_across_an_edge():
    # lying flat on the top face: both end spheres
    P, N, D = collide(Capsule("A", 0.05, 0.4), pose(Rotation.from_euler("y", np.pi / 2), (0, 0, 0.5 + 0.04)),
                      Box("B", (1.0, 1.0, 1.0)), pose())
    np.testing.assert_allclose(D, [0.01, 0.01], rtol=1e-12)
    np.testing.assert_allclose(sorted(P[:, 0]), [-0.2, 0.2], atol=1e-12)
    # across the top edge x = 0.5 at 45 degrees: the deepest point of the axis is over the edge
    R = Rotation.from_euler("y", -np.pi / 4)  # the axis along (-1, 0, 1) / sqrt 2, square to the edge's normal
    c = np.array([0.5, 0.2, 0.5]) + 0.04 * np.array([1, 0, 1]) / np.sqrt(2)
    P, N, D = collide(Capsule("A", 0.05, 0.4), pose(R, c), Box("B", (1.0, 1.0, 1.0)), pose())
    # the axis passes the edge at distance 0.04
    np.testing.assert_allclose(D, [0.01], rtol=1e-6)
    np.testing.assert_allclose(N[0], np.array([1, 0, 1]) / np.sqrt(2), atol=1e-6)


# -- random placements against independent references ---------------------------------------------------

def box_sd(x, T, size):
    """Signed distance of world point x to the box (numpy, written apart from the library's)."""
    y = T[:3, :3].T @ (x - T[:3, 3])
    q = np.abs(y) - np.asarray(size) / 2
    return np.linalg.norm(np.maximum(q, 0)) + min(q.max(), 0.0)


def segment_distance(ca, ua, ha, cb, ub, hb):
    f = lambda st: np.sum((ca + st[0] * ua - cb - st[1] * ub) ** 2)
    best = min((minimize(f, x0, bounds=[(-ha, ha), (-hb, hb)], method="L-BFGS-B", options={"ftol": 1e-15,
                                                                                            "gtol": 1e-12})
                for x0 in ([0, 0], [ha, -hb], [-ha, hb])), key=lambda r: r.fun)
    return np.sqrt(max(best.fun, 0.0))


def support(T, size, d):
    """h(d) = max over the box of d . x (d one direction or rows of them)."""
    return d @ T[:3, 3] + np.abs(d @ T[:3, :3]) @ (np.asarray(size) / 2)


def box_penetration(Ta, sa, Tb, sb):
    """min over unit d of h_B(d) + h_A(-d): how far A must move along d to leave B; (depth, d)."""
    f = lambda d: support(Tb, sb, d) + support(Ta, sa, -d)
    g = np.random.default_rng(0).normal(size=(4000, 3))
    g /= np.linalg.norm(g, axis=1)[:, None]
    vals = f(g)
    best = (np.inf, None)
    for k in np.argsort(vals)[:3]:
        th, ph = np.arccos(np.clip(g[k, 2], -1, 1)), np.arctan2(g[k, 1], g[k, 0])
        sph = lambda a: np.array([np.sin(a[0]) * np.cos(a[1]), np.sin(a[0]) * np.sin(a[1]), np.cos(a[0])])
        r = minimize(lambda a: f(sph(a)), [th, ph], method="Nelder-Mead",
                     options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000})
        if r.fun < best[0]:
            best = (r.fun, sph(r.x))
    return best


rotations = st.tuples(*[st.floats(-np.pi, np.pi)] * 3).map(lambda e: Rotation.from_euler("xyz", e))
points = st.tuples(*[st.floats(-0.3, 0.3)] * 3).map(np.array)
sizes = st.tuples(*[st.floats(0.05, 0.5)] * 3)
SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)


@SETTINGS
@given(Ra=rotations, Rb=rotations, pa=points, pb=points, ra=st.floats(0.02, 0.2), rb=st.floats(0.02, 0.2),
       la=st.floats(0.0, 0.6), lb=st.floats(0.0, 0.6))
def test_capsules_random(Ra, Rb, pa, pb, ra, rb, la, lb):
    Ta, Tb = pose(Ra, pa), pose(Rb, pb)
    ua, ub = Ra.as_matrix()[:, 2], Rb.as_matrix()[:, 2]
    dist = segment_distance(pa, ua, la / 2, pb, ub, lb / 2)
    P, N, D = collide(Capsule("A", ra, la), Ta, Capsule("B", rb, lb), Tb)
    if dist > ra + rb + 1e-9:
        assert len(D) == 0
    elif dist < ra + rb - 1e-9:
        assert 1 <= len(D) <= 2
        if dist < 1e-9:  # the axes meet: any normal pushes them apart, the depth is all there is to check
            np.testing.assert_allclose(D.max(), ra + rb, atol=1e-7)
            return
        np.testing.assert_allclose(D.max(), ra + rb - dist, atol=1e-7)
        np.testing.assert_allclose(np.linalg.norm(N, axis=1), 1.0, rtol=1e-12)
        for x, n, d in zip(P, N, D):  # midway between the surfaces: x -+ d/2 n is on a's, on b's
            for y, c, u, h, r in ((x - d / 2 * n, pa, ua, la / 2, ra), (x + d / 2 * n, pb, ub, lb / 2, rb)):
                t = np.clip((y - c) @ u, -h, h)
                assert abs(np.linalg.norm(y - c - t * u) - r) <= 1e-7


@SETTINGS
@given(R=rotations, c=points, size=sizes, r=st.floats(0.01, 0.2))
def test_sphere_box_random(R, c, size, r):
    T = pose(R)
    sd = box_sd(c, T, size)
    P, N, D = collide(Sphere("A", r), pose(p=c), Box("B", size), T)
    if sd > r + 1e-12:
        assert len(D) == 0
    elif sd < r - 1e-12:
        np.testing.assert_allclose(D, [r - sd], atol=1e-12)
        assert abs(np.linalg.norm(P[0] - D[0] / 2 * N[0] - c) - r) < 1e-12  # the sphere's deepest point
        assert abs(box_sd(P[0] + D[0] / 2 * N[0], T, size)) < 1e-12  # on the box's surface
        # the normal leads out of the box: a step along it increases the distance at the rate 1
        np.testing.assert_allclose((box_sd(c + 1e-7 * N[0], T, size) - sd) / 1e-7, 1.0, atol=1e-5)


@SETTINGS
@given(Ra=rotations, Rb=rotations, pa=points, pb=points, sa=sizes, sb=sizes)
def test_box_box_random(Ra, Rb, pa, pb, sa, sb):
    Ta, Tb = pose(Ra, pa), pose(Rb, pb)
    depth, d = box_penetration(Ta, sa, Tb, sb)
    P, N, D = collide(Box("A", sa), Ta, Box("B", sb), Tb)
    if depth < -1e-9:
        assert len(D) == 0
        return
    if depth < 1e-9:
        return
    assert 1 <= len(D) <= 8
    np.testing.assert_allclose(N, np.tile(N[0], (len(D), 1)), atol=1e-15)
    # along the normal found, A must move at least the least depth, and at most 1/EDGE_BIAS of it (a face
    # is preferred to an edge-edge axis unless the edge's is smaller by that factor)
    along = support(Tb, sb, N[0]) + support(Ta, sa, -N[0])
    assert depth - 1e-9 <= along <= depth / EDGE_BIAS + 1e-9
    assert D.max() <= along + 1e-9
    for x, n, dx in zip(P, N, D):  # midway between the surfaces: x -+ d/2 n is on A's, on B's
        assert abs(box_sd(x - dx / 2 * n, Ta, sa)) <= 1e-9 and abs(box_sd(x + dx / 2 * n, Tb, sb)) <= 1e-9


def lowest(kind, T, size, n):
    """min over the solid of n . x (the support function in -n), numpy."""
    R, c = T[:3, :3], T[:3, 3]
    if kind == "box":
        return n @ c - np.abs(R.T @ n) @ (np.asarray(size) / 2)
    r, l = size[0], size[1]
    u = R[:, 2]
    ends = n @ c - abs(n @ u) * l / 2
    if kind == "capsule":
        return ends - r
    return ends - r * np.sqrt(max(0.0, 1 - (n @ u) ** 2))  # a cylinder: the rim, across the axis


@SETTINGS
@given(R=rotations, c=points, n=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda n: np.linalg.norm(n) > 0.1),
       h=st.floats(-0.3, 0.3), kind=st.sampled_from(["box", "capsule", "cylinder"]), size=sizes)
def test_solids_against_a_half_space_random(R, c, n, h, kind, size):
    """The deepest contact of each solid with a half-space is its support point: depth = h - min n . x."""
    T = pose(R, c)
    u = np.array(n) / np.linalg.norm(n)
    geometry = {"box": Box("A", size), "capsule": Capsule("A", size[0], size[1]),
                "cylinder": Cylinder("A", size[0], size[1])}[kind]
    P, N, D = collide(geometry, T, HalfSpace(n, h))
    depth = h - lowest(kind, T, size if kind == "box" else (size[0], size[1]), u)
    if depth <= 1e-12:
        assert len(D) == 0
        return
    np.testing.assert_allclose(D.max(), depth, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(N, np.tile(u, (len(D), 1)), atol=1e-15)
    np.testing.assert_allclose(P @ u, h - D / 2, atol=1e-12)  # midway: half the depth below the plane


@SETTINGS
@given(Rb=rotations, Ra=rotations, c=points, size=sizes, r=st.floats(0.01, 0.2), l=st.floats(0.0, 0.6))
def test_capsule_box_random(Rb, Ra, c, size, r, l):
    """A capsule against a box: never deeper than the axis's deepest point (dense sampling of the box's
    signed distance along the axis); that depth exactly unless both ends touch (then their two spheres)."""
    Tb, Ta = pose(Rb), pose(Ra, c)
    u = Ra.as_matrix()[:, 2]
    sd = lambda t: box_sd(c + t * u, Tb, size)
    ts = np.linspace(-l / 2, l / 2, 2001)
    y = (c + ts[:, None] * u - Tb[:3, 3]) @ Tb[:3, :3]  # the sampled axis in the box's frame
    q = np.abs(y) - np.asarray(size) / 2
    sds = np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0.0)
    k = int(np.argmin(sds))
    best = minimize(lambda t: sd(t[0]), [ts[k]], bounds=[(-l / 2, l / 2)], method="L-BFGS-B").fun \
        if l > 0 else sd(0.0)
    best = min(best, sds.min())
    P, N, D = collide(Capsule("A", r, l), Ta, Box("B", size), Tb)
    ends = [sd(-l / 2) < r, sd(l / 2) < r]
    if best > r + 1e-9:
        assert len(D) == 0
    elif best < r - 1e-9:
        assert 1 <= len(D) <= 2
        assert D.max() <= r - best + 1e-8
        if not all(ends):
            np.testing.assert_allclose(D, [r - best], atol=1e-8)
        if best < 0:  # the axis itself enters the box: the depth is that of its deepest point, no more
            return
        for x, nn, d in zip(P, N, D):  # the box's surface point, the capsule's surface point
            assert abs(box_sd(x + d / 2 * nn, Tb, size)) < 1e-9
            y = x - d / 2 * nn
            t = np.clip((y - c) @ u, -l / 2, l / 2)
            assert abs(np.linalg.norm(y - c - t * u) - r) < 1e-9


@SETTINGS
@given(R=rotations, c=points, p=points, r=st.floats(0.01, 0.2), rb=st.floats(0.01, 0.2), l=st.floats(0.0, 0.6))
def test_sphere_capsule_random(R, c, p, r, rb, l):
    u = R.as_matrix()[:, 2]
    dist = segment_distance(p, np.array([1.0, 0, 0]), 0.0, c, u, l / 2)
    P, N, D = collide(Sphere("A", r), pose(p=p), Capsule("B", rb, l), pose(R, c))
    if dist > r + rb + 1e-9:
        assert len(D) == 0
    elif dist < r + rb - 1e-9:
        np.testing.assert_allclose(D, [r + rb - dist], atol=1e-7)
        if dist > 1e-6:
            assert abs(np.linalg.norm(P[0] - D[0] / 2 * N[0] - p) - r) < 1e-9
