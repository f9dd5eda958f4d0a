"""The C++ narrow phase (core/contact/narrow_phase.cpp, through ``_core.find_contacts``) pinned bit for bit: it was
ported from the numba kernels with their order of operations and compared with them on every case below (all
identical, signed zeros included; the numba code is in git's history, commit 9e2c482); the SHA-256 of its answers
was then recorded (tests/data/narrow_phase_golden.json, ``DYNAMICS_RECORD_GOLDEN=1 pytest`` this file to record
again after a change that is meant to move bits) and every later change is compared with it.  Closed forms and
independent references for the same functions are tests/test_contact_geometry.py's.

Static scenes (every geometry on body -1, its world pose given) test the pair functions alone: for each of the 21
kind pairs (a <= b) of sphere, point, capsule, cylinder, box and plane, hundreds of seeded random poses (a quarter
of them on a grid of signed axis permutations and quarter metres, where the ties of the pair functions -- equal
overlaps, parallel edges, a centre on a face -- happen), plus the hand-made cases: coincident centres, parallel
and collinear capsules, box-box face and edge contacts, a capsule whose axis enters a box.  Scenes on free bodies
test the whole path, kinematics included.

The bounds tests: every array checked before any C++ runs (dtype, layout, shape, index range, the buffer's size)
-> ValueError naming the argument; a million pairs with a buffer of 3 -> 3 contacts, nothing written past it.
"""

import hashlib
import json
import os

import numpy as np
import pytest

import dynamics
from dynamics import Box, Capsule, Cylinder, Ground, Sphere, _core
from dynamics.contact.narrow_phase import find_contacts, scene_poses
from dynamics.contact.scene import BOX, CAPSULE, CYLINDER, MAX_PER_PAIR, PLANE, POINT, SPHERE, Scene, build_scene
from dynamics.contact.scene import bounding_radius

KINDS = (SPHERE, POINT, CAPSULE, CYLINDER, BOX, PLANE)
NAMES = {SPHERE: "sphere", POINT: "point", CAPSULE: "capsule", CYLINDER: "cylinder", BOX: "box", PLANE: "plane"}
PAIRS = [(a, b) for a in KINDS for b in KINDS if a <= b]
N_RANDOM = 400  # random poses per kind pair
GOLDEN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "narrow_phase_golden.json")
RECORD = os.environ.get("DYNAMICS_RECORD_GOLDEN") == "1"


class Digest:
    """The SHA-256 of a sequence of the core's answers (every array's bytes, in order) and how many contacts."""

    def __init__(self):
        self.sha, self.contacts = hashlib.sha256(), 0

    def add(self, *arrays):
        for a in arrays:
            self.sha.update(np.ascontiguousarray(a).tobytes())

    def contacts_of(self, model, scene, q):
        c = core_contacts(model, scene, q)
        self.add(*c)
        self.contacts += len(c[0])
        return len(c[0])


def assert_recorded(name, digest):
    """The digest equals the recorded one (or, recording, is written)."""
    recorded = json.load(open(GOLDEN)) if os.path.exists(GOLDEN) else {}
    got = {"sha256": digest.sha.hexdigest(), "contacts": digest.contacts}
    if RECORD:
        recorded[name] = got
        with open(GOLDEN, "w") as f:
            json.dump(recorded, f, indent=1, sort_keys=True)
        return
    assert name in recorded, f"{name}: nothing recorded (DYNAMICS_RECORD_GOLDEN=1 to record)"
    assert got == recorded[name], f"{name}: the core's contacts changed ({got} against {recorded[name]})"


@pytest.fixture(scope="module")
def model():
    """Any model: the static scenes' geometry is on the world (body -1), its kinematics not read."""
    return dynamics.load_urdf("planar_2r")


# -- scenes -----------------------------------------------------------------------------------------------------

def random_rotation(rng, grid):
    """A rotation: uniform (a normalised random quaternion), or on the grid a signed permutation of the axes."""
    if grid:
        R = np.eye(3)[rng.permutation(3)] * rng.choice([-1.0, 1.0], 3)[:, None]
        return R * np.linalg.det(R)  # proper
    x, y, z, w = rng.normal(size=4)
    n = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def random_size(kind, rng, grid):
    pick = (lambda: rng.choice([0.25, 0.5, 0.75])) if grid else (lambda: rng.uniform(0.05, 0.6))
    if kind == SPHERE:
        return (pick(), 0.0, 0.0)
    if kind in (CAPSULE, CYLINDER):
        return (0.5 * pick(), 2 * pick(), 0.0)
    if kind == BOX:
        return (2 * pick(), 2 * pick(), 2 * pick())
    return (0.0, 0.0, 0.0)  # point, plane


class Geometries:
    """Geometry records for a static scene, and its pairs."""

    def __init__(self):
        self.kind, self.size, self.R, self.p, self.pa, self.pb = [], [], [], [], [], []

    def add(self, kind, size, R, p):
        self.kind.append(kind), self.size.append(size), self.R.append(np.asarray(R, float))
        self.p.append(np.asarray(p, float))
        return len(self.kind) - 1

    def plane(self, n, h):
        """The half-space n . x <= h: R's third column n, p = h n."""
        n = np.asarray(n, float) / np.linalg.norm(n)
        t = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
        t /= np.linalg.norm(t)
        return self.add(PLANE, (0, 0, 0), np.column_stack([t, np.cross(n, t), n]), h * n)

    def pair(self, a, b):
        if self.kind[a] > self.kind[b]:
            a, b = b, a
        self.pa.append(a), self.pb.append(b)

    def scene(self, K=None):
        kind = np.array(self.kind, np.int64)
        size = np.array(self.size, float).reshape(-1, 3)
        pa, pb = np.array(self.pa, np.int64), np.array(self.pb, np.int64)
        K = int(MAX_PER_PAIR[kind[pa], kind[pb]].sum()) if K is None else K
        ng = len(kind)
        return Scene(np.full(ng, -1, np.int64), kind, size, np.array(self.R).reshape(-1, 3, 3),
                     np.array(self.p).reshape(-1, 3), np.array([bounding_radius(k, s) for k, s in zip(kind, size)]),
                     pa, pb, tuple(f"g{g}" for g in range(ng)), K)


def random_pair(G, ka, kb, rng):
    """Geometries of kinds ka and kb at random poses that overlap about half the time."""
    grid = rng.random() < 0.25
    ca = rng.choice([-0.5, -0.25, 0, 0.25, 0.5], 3) if grid else rng.uniform(-1, 1, 3)
    if kb == PLANE:
        n = random_rotation(rng, grid)[:, 2]
        h = float(n @ ca) - (rng.choice([-0.25, 0, 0.25, 0.5]) if grid else rng.uniform(-0.4, 0.6))
        a = (G.plane(rng.normal(size=3), rng.uniform(-1, 1)) if ka == PLANE
             else G.add(ka, random_size(ka, rng, grid), random_rotation(rng, grid), ca))
        G.pair(a, G.plane(n, h))
        return
    off = rng.choice([-0.5, -0.25, 0, 0.25, 0.5], 3) if grid else rng.uniform(-0.7, 0.7, 3)
    if ka == POINT:  # a point has no volume: closer, or it rarely touches
        off = 0.5 * off
    a = G.add(ka, random_size(ka, rng, grid), random_rotation(rng, grid), ca)
    G.pair(a, G.add(kb, random_size(kb, rng, grid), random_rotation(rng, grid), ca + off))


# -- the comparison -------------------------------------------------------------------------------------------

def core_contacts(model, scene, q):
    return _core.find_contacts(model.core, *scene.arrays, np.asarray(q, float), scene.max_contacts)


@pytest.mark.parametrize("ka, kb", PAIRS, ids=[f"{NAMES[a]}-{NAMES[b]}" for a, b in PAIRS])
def test_random_poses_bit_identical(model, ka, kb):
    """N_RANDOM seeded poses of the kind pair: the same contacts in the same order with the same bits, and
    enough of them touch that the pair function runs (two points never do).  Plane-plane, never paired by
    build_scene, has no room in a scene's buffer: it gets 8 per pair here."""
    rng = np.random.default_rng(1000 + 10 * ka + kb)
    G = Geometries()
    for _ in range(N_RANDOM):
        random_pair(G, ka, kb, rng)
    scene = G.scene(8 * N_RANDOM if ka == kb == PLANE else None)
    d = Digest()
    n = d.contacts_of(model, scene, model.neutral())
    assert n >= (0 if ka == kb == POINT else N_RANDOM // 10)  # two points never touch
    assert_recorded(f"random {NAMES[ka]}-{NAMES[kb]}", d)


def special_cases():
    """The hand-made degenerate and boundary cases: coincident centres, parallel capsules, box faces and edges,
    a capsule whose axis crosses a box."""
    G, I = Geometries(), np.eye(3)
    flip = np.diag([1.0, -1.0, -1.0])  # the z axis reversed: an anti-parallel capsule
    c = np.array([0.1, -0.2, 0.3])
    for ka, kb in PAIRS:  # coincident centres, same and crossed axes
        if PLANE in (ka, kb):
            continue
        for Rb in (I, flip, random_rotation(np.random.default_rng(ka + 7 * kb), False)):
            G.pair(G.add(ka, random_size(ka, np.random.default_rng(kb), True), I, c),
                   G.add(kb, random_size(kb, np.random.default_rng(ka), True), Rb, c))
    for k1 in (CAPSULE, CYLINDER):  # parallel and anti-parallel axes, side by side, collinear, overlapping or not
        for k2 in (CAPSULE, CYLINDER):
            for R2 in (I, flip):
                for off in ([0.1, 0, 0.2], [0.05, 0.05, 0.9], [0, 0, 0.5], [0, 0, 1.5], [0.3, 0, 0], [0, 0, 0]):
                    G.pair(G.add(k1, (0.2, 1.0, 0), I, c), G.add(k2, (0.15, 0.8, 0), R2, c + np.array(off)))
    a45 = np.array([[1, 0, 0], [0, np.sqrt(0.5), -np.sqrt(0.5)], [0, np.sqrt(0.5), np.sqrt(0.5)]])
    b45 = np.array([[np.sqrt(0.5), 0, np.sqrt(0.5)], [0, 1, 0], [-np.sqrt(0.5), 0, np.sqrt(0.5)]])
    for R2, off in ((I, [0, 0, 0.9]), (I, [0.3, 0.2, 0.9]), (I, [0.5, 0.5, 0.5]), (a45, [0, 0, 1.1]),
                    (a45 @ b45, [0.7, 0.7, 0.7]), (a45 @ b45, [0.8, 0.1, 0.9]), (b45, [1.0, 0, 1.0]),
                    (a45 @ b45, [0, 0, 0])):  # box-box: faces stacked, corners, edges crossed
        G.pair(G.add(BOX, (1, 1, 1), I, c), G.add(BOX, (1.0, 0.6, 0.8), R2, c + np.array(off)))
    for k in (CAPSULE, CYLINDER):  # an axis entering a box, through its centre, along a face, lying on it
        for R2, off in ((I, [0, 0, 0.9]), (b45, [0.2, 0.1, 0.3]), (a45, [0.5, 0, 0]), (I, [0, 0, 0]),
                        (np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]]), [0, 0, 0.55])):
            G.pair(G.add(k, (0.05, 2.0, 0), R2, c + np.array(off)), G.add(BOX, (1, 1, 1), I, c))
    for k in (SPHERE, POINT):  # centres on a box's face, edge, corner, centre
        for off in ([0.5, 0, 0], [0.5, 0.5, 0], [0.5, 0.5, 0.5], [0, 0, 0], [0.2, 0.2, 0]):
            G.pair(G.add(k, (0.1 if k == SPHERE else 0.0, 0, 0), I, c + np.array(off)), G.add(BOX, (1, 1, 1), I, c))
    for k in (SPHERE, POINT, CAPSULE, CYLINDER, BOX):  # lying flat on a plane, upright, touching exactly
        for R in (I, flip, np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]])):
            for h in (0.0, 0.1, 0.5):
                G.pair(G.add(k, random_size(k, np.random.default_rng(3), True), R, [0, 0, h]), G.plane([0, 0, 1], 0))
    return G.scene()


def test_special_cases_bit_identical(model):
    d = Digest()
    assert d.contacts_of(model, special_cases(), model.neutral()) > 50
    assert_recorded("special cases", d)


# -- on moving bodies: kinematics included ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def free_bodies():
    """Four free bodies (one of each primitive, some off their body's origin) and a box, a sphere and the
    ground in the world, every pair."""
    T = np.eye(4)
    T[:3, :3] = random_rotation(np.random.default_rng(5), False)
    T[:3, 3] = (0.05, -0.02, 0.1)
    m = dynamics.load_urdf("planar_2r")
    m = dynamics.add_free_body(m, "ball", Sphere("ball", 0.2, offset=(0.05, 0.0, 0.02)), 1.0)
    m = dynamics.add_free_body(m, "pill", Capsule("pill", 0.1, 0.6, pose=T), 1.0)
    m = dynamics.add_free_body(m, "can", Cylinder("can", 0.15, 0.4), 1.0)
    m = dynamics.add_free_body(m, "brick", Box("brick", (0.5, 0.3, 0.2), pose=T), 1.0)
    Tw = np.eye(4)
    Tw[:3, 3] = (0.3, 0.2, 0.25)
    world = [Ground(), Box("world", (0.6, 0.6, 0.5), pose=Tw, name="table"), Sphere("world", 0.3, name="rock")]
    return m, build_scene(m, world=world)


def random_configuration(model, rng):
    """The four free bodies at random positions in a small cube and random orientations."""
    q = model.neutral()
    for name in ("ball", "pill", "can", "brick"):
        s = model.q_slice(name + "_joint")
        quat = rng.normal(size=4)
        q[s] = np.concatenate([rng.uniform(-0.4, 0.6, 3), quat / np.linalg.norm(quat)])
    return q


def test_free_bodies_bit_identical(free_bodies):
    """300 configurations of the free bodies: the core's contacts and geometry poses (scene_poses) as recorded, bit
    for bit."""
    model, scene = free_bodies
    rng = np.random.default_rng(7)
    d = Digest()
    for _ in range(300):
        q = random_configuration(model, rng)
        d.contacts_of(model, scene, q)
        T = scene_poses(model, scene, q)
        d.add(T)
        assert np.all(T[:, 3] == [0, 0, 0, 1])
    assert d.contacts > 300
    assert_recorded("free bodies", d)


def test_find_contacts_keeps_its_contract(free_bodies):
    """The public function: names, copies of the outputs, the same InputError for a bad q."""
    model, scene = free_bodies
    q = random_configuration(model, np.random.default_rng(11))
    c = find_contacts(model, scene, q)
    pair, point, normal, depth = core_contacts(model, scene, q)
    assert np.array_equal(c.pair, pair) and np.array_equal(c.point, point) and np.array_equal(c.depth, depth)
    assert c.a == tuple(scene.names[scene.pair_a[k]] for k in pair)
    assert c.pair.dtype == np.int64 and c.point.flags.c_contiguous and c.point.shape == (len(pair), 3)
    with pytest.raises(dynamics.InputError, match="q: expected"):
        find_contacts(model, scene, q[:3])


# -- bounds --------------------------------------------------------------------------------------------------

def arguments(model, scene, q):
    return dict(model=model.core, body=scene.body, kind=scene.kind, size=scene.size, R=scene.R, p=scene.p,
                radius=scene.radius, pair_a=scene.pair_a, pair_b=scene.pair_b, q=np.asarray(q, float),
                K=scene.max_contacts)


def strided(a):
    """A non-contiguous array of a's values."""
    b = np.repeat(a, 2, axis=0)[::2]
    assert not b.flags.c_contiguous or a.shape[0] <= 1
    return b


BAD = [
    ("body", lambda a: a["body"].astype(np.int32), "body: expected a C-contiguous int64"),
    ("body", lambda a: a["body"].astype(float), "body"),
    ("body", lambda a: strided(a["body"]), "non-contiguous"),
    ("body", lambda a: a["body"].tolist(), "body: expected"),
    ("body", lambda a: a["body"][:-1], "R: expected shape"),
    ("body", lambda a: np.where(a["body"] >= 0, 99, -1), "body: expected body indices"),
    ("body", lambda a: np.where(a["body"] >= 0, a["body"], -2), "body: expected body indices"),
    ("kind", lambda a: a["kind"] + 6, "kind: expected kinds in"),
    ("kind", lambda a: a["kind"] - 7, "kind: expected kinds in"),
    ("kind", lambda a: a["kind"][:-1], "kind: expected"),
    ("size", lambda a: a["size"].astype(np.float32), "size: expected a C-contiguous float64"),
    ("size", lambda a: np.asfortranarray(np.repeat(a["size"], 2, axis=1)[:, ::2]), "size"),
    ("size", lambda a: a["size"][:, :2].copy(), "size: expected shape"),
    ("R", lambda a: a["R"].reshape(-1, 9), "R: expected"),
    ("R", lambda a: a["R"].transpose(0, 2, 1), "non-contiguous"),
    ("p", lambda a: a["p"][:-1], "p: expected shape"),
    ("radius", lambda a: a["radius"][None], "radius"),
    ("pair_a", lambda a: a["pair_a"] + 1000, "pair_a: expected geometry indices"),
    ("pair_a", lambda a: a["pair_a"] - 1000, "pair_a: expected geometry indices"),
    ("pair_b", lambda a: a["pair_b"][:-1], "pair_b: expected"),
    ("pair_b", lambda a: np.full_like(a["pair_b"], 2 ** 62), "pair_b: expected geometry indices"),
    ("pair_a", lambda a: np.full_like(a["pair_a"], np.flatnonzero(a["kind"] == PLANE)[0]), "kind\\[a\\] <= kind"),
    ("q", lambda a: a["q"][:-1], "q: expected"),
    ("q", lambda a: np.full_like(a["q"], np.nan), "q: expected a finite"),
    ("q", lambda a: a["q"].astype(np.float32), "q: expected a C-contiguous float64"),
    ("K", lambda a: -1, "K: expected"),
    ("K", lambda a: 10 ** 12, "K: expected"),
]


@pytest.mark.parametrize("name, change, message", BAD, ids=[f"{b[0]}-{i}" for i, b in enumerate(BAD)])
def test_bad_arrays_are_value_errors(free_bodies, name, change, message):
    model, scene = free_bodies
    args = arguments(model, scene, model.neutral())
    args[name] = change(args)
    with pytest.raises(ValueError, match=message):
        _core.find_contacts(*args.values())
    if name in ("body", "R", "p", "q"):
        with pytest.raises(ValueError, match=message):
            _core.scene_poses(args["model"], args["body"], args["R"], args["p"], args["q"])


def test_a_million_pairs_in_a_tiny_buffer(free_bodies):
    """10^6 overlapping pairs and a buffer of 3: the first 3 contacts, the rest dropped, nothing written past
    it."""
    model, scene = free_bodies
    q = model.neutral()
    a = arguments(model, scene, q)
    g = int(np.flatnonzero(scene.kind == SPHERE)[0])  # a sphere against itself: always one contact
    a["pair_a"] = a["pair_b"] = np.full(10 ** 6, g, np.int64)
    a["K"] = 3
    pair, point, normal, depth = _core.find_contacts(*a.values())
    assert pair.tolist() == [0, 1, 2] and point.shape == (3, 3) and depth.shape == (3,)
    a["K"] = 0
    assert _core.find_contacts(*a.values())[0].shape == (0,)


def test_empty_scene(model):
    scene = Geometries().scene()
    pair, point, normal, depth = core_contacts(model, scene, model.neutral())
    assert pair.shape == (0,) and point.shape == (0, 3) and normal.shape == (0, 3) and depth.shape == (0,)
    assert _core.scene_poses(model.core, scene.body, scene.R, scene.p, model.neutral()).shape == (0, 4, 4)


def test_a_buffer_bigger_than_needed(free_bodies):
    """K beyond the scene's max_contacts (up to 2^31) gives the same contacts; only the room a scene can fill (8
    per pair) is allocated."""
    model, scene = free_bodies
    q = random_configuration(model, np.random.default_rng(3))
    a = arguments(model, scene, q)
    want = _core.find_contacts(*a.values())
    a["K"] = 2 ** 31 - 1
    for w, g in zip(want, _core.find_contacts(*a.values())):
        assert np.array_equal(w, g)


@pytest.mark.parametrize("rel", ["go1_description/urdf/go1.urdf", "panda_description/urdf/panda_collision.urdf"])
def test_robot_self_collision_bit_identical(rel):
    """A robot's URDF primitives with self-collision and the ground, at 100 random configurations (revolute joints
    and a floating base through both kinematics): the same contacts, bit for bit."""
    from tests.robots import erd, random_state

    model = dynamics.load_urdf(erd(rel), collision=True, floating_base="go1" in rel, strict_inertia=False,
                               mimic="independent")
    scene = build_scene(model, self_collision=True)
    rng = np.random.default_rng(13)
    d = Digest()
    for _ in range(100):
        q = random_state(model, rng)[0]
        if "go1" in rel:
            q[2] = rng.uniform(0.0, 0.4)  # the base near the ground
        d.contacts_of(model, scene, q)
    assert d.contacts > 100
    assert_recorded(f"self-collision {rel.split('/')[0]}", d)


def test_non_finite_scenes_do_not_crash(model):
    """Scenes of nan, inf, huge and tiny numbers (which build_scene never makes: its sizes and poses are checked
    finite) still give a bounded answer: at most K contacts, each of a pair of the scene."""
    rng = np.random.default_rng(17)
    values = np.array([np.nan, np.inf, -np.inf, 0.0, -0.0, 1e308, -1e308, 1e-308, 1.0, -1.0, 0.5])
    for _ in range(200):
        ng, npairs = rng.integers(1, 6), rng.integers(0, 12)
        kind = rng.integers(0, 6, ng)
        pa, pb = rng.integers(0, ng, npairs), rng.integers(0, ng, npairs)
        swap = kind[pa] > kind[pb]
        pa[swap], pb[swap] = pb[swap], pa[swap]
        size, R, p, radius = (rng.choice(values, shape) for shape in ((ng, 3), (ng, 3, 3), (ng, 3), (ng,)))
        K = int(rng.integers(0, 8 * npairs + 1))
        pair, point, normal, depth = _core.find_contacts(model.core, np.full(ng, -1), kind, size, R, p, radius,
                                                         pa, pb, model.neutral(), K)
        assert len(pair) <= K and point.shape == normal.shape == (len(pair), 3) and depth.shape == (len(pair),)
        assert np.all((pair >= 0) & (pair < npairs))
