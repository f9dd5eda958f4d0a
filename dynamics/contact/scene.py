"""Contact geometry of a model and its world, packed into flat arrays for the core's narrow phase.

:func:`build_scene` resolves the geometry (``model.collision_geometry`` and/or the declarations of
:mod:`dynamics.contact.geometry`) against the model's frames, lists the candidate pairs once (the filtering
below) and returns a :class:`Scene`.  For geometry ``g`` (ng of them):

==========  ===============  ==========================================================================
field       shape            meaning
==========  ===============  ==========================================================================
body        (ng,) int64      body the geometry is fixed to; -1 = static (the world)
kind        (ng,) int64      SPHERE, POINT, CAPSULE, CYLINDER, BOX or PLANE (module constants)
size        (ng,3)           sphere (r, 0, 0); box full edges (x, y, z); capsule, cylinder (r, length, 0);
                             point and plane (0, 0, 0)
R, p        (ng,3,3),(ng,3)  pose in the body frame (the world pose for body -1).  A plane's (a half-space
                             ``n . x <= offset``): R's third column is n, p = offset n
radius      (ng,)            bounding-sphere radius about p (inf for a plane)
pair_a/b    (npairs,) int64  candidate pairs, each ordered so that ``kind[a] <= kind[b]``
==========  ===============  ==========================================================================

plus ``names`` (ng geometry names, for messages and outputs) and ``max_contacts`` (the contacts the pairs can
produce at once: the sum over pairs of :data:`MAX_PER_PAIR`, the length of a
:class:`~dynamics.contact.narrow_phase.ContactBuffer`).

Pair filtering: two static geometries never; a moving geometry against the world's objects always; two
geometries of one kinematic tree (a robot, counting a fixed base's links as the robot's) only with
``self_collision=True`` and never on the same body or on a parent and its child; geometries of two trees (the
robot and a free body, two free bodies) always.  Then ``exclude`` drops pairs, or ``pairs`` replaces the
automatic list.  A name in ``exclude`` or ``pairs`` matches a geometry by its name, its frame, the name of its
body's link, or ``"world"`` for static geometry.
"""

import difflib
import itertools
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..joints import JOINT_FREE
from .geometry import PLANES, PRIMITIVES, CollisionGeometry, Ground

#: geometry kinds (Scene.kind); pairs are ordered by them
SPHERE, POINT, CAPSULE, CYLINDER, BOX, PLANE = 0, 1, 2, 3, 4, 5
KIND_CODES = {"sphere": SPHERE, "point": POINT, "capsule": CAPSULE, "cylinder": CYLINDER, "box": BOX,
              "plane": PLANE}
#: the most contacts a pair writes, by the pair's kinds (ordered): box-plane its 8 vertices, box-box a clipped
#: manifold of up to 8 points, cylinder-plane 3 rim points of one cap and 1 of the other, capsules their 2 ends
MAX_PER_PAIR = np.ones((6, 6), np.int64)
for _a, _b, _n in ((CAPSULE, CAPSULE, 2), (CAPSULE, CYLINDER, 2), (CYLINDER, CYLINDER, 2), (CAPSULE, BOX, 2),
                   (CYLINDER, BOX, 2), (CAPSULE, PLANE, 2), (CYLINDER, PLANE, 4), (BOX, BOX, 8), (BOX, PLANE, 8),
                   (PLANE, PLANE, 0)):
    MAX_PER_PAIR[_a, _b] = MAX_PER_PAIR[_b, _a] = _n
MAX_PER_PAIR.flags.writeable = False
#: most geometries and pairs a scene takes (a robot has tens to hundreds of primitives)
MAX_GEOMETRIES = 10_000
MAX_PAIRS = 100_000


class SceneArrays(NamedTuple):
    """The numeric part of a :class:`Scene`: what the core's narrow phase takes (``core/contact/scene.hpp``)."""

    body: np.ndarray
    kind: np.ndarray
    size: np.ndarray
    R: np.ndarray
    p: np.ndarray
    radius: np.ndarray
    pair_a: np.ndarray
    pair_b: np.ndarray


class Scene(NamedTuple):
    """Geometry and candidate pairs as flat read-only arrays (module docstring).  Compiled code takes
    :attr:`arrays` (the same arrays without the names)."""

    body: np.ndarray
    kind: np.ndarray
    size: np.ndarray
    R: np.ndarray
    p: np.ndarray
    radius: np.ndarray
    pair_a: np.ndarray
    pair_b: np.ndarray
    names: tuple
    max_contacts: int

    @property
    def arrays(self) -> SceneArrays:
        return SceneArrays(*self[:8])

    @property
    def npairs(self) -> int:
        return self.pair_a.shape[0]


def _frozen(a, dtype=np.float64):
    a = np.ascontiguousarray(a, dtype=dtype)
    a.flags.writeable = False
    return a


def bounding_radius(kind, size):
    """Radius of the smallest sphere about the primitive's origin that holds it."""
    r, l, z = size
    if kind == SPHERE:
        return r
    if kind == CAPSULE:
        return r + l / 2
    if kind == CYLINDER:
        return float(np.hypot(r, l / 2))
    if kind == BOX:
        return float(np.linalg.norm(size)) / 2
    return np.inf if kind == PLANE else 0.0


class _Item(NamedTuple):
    """One resolved geometry while the scene is built."""
    name: str
    body: int
    frame: str
    kind: int
    size: tuple
    T: np.ndarray  # 4x4 in the body (world for -1)
    world: bool  # one of the world's objects (not the model's)


def _unknown(name, names, what, noun):
    """An InputError for an unknown name, with the closest known ones."""
    near = difflib.get_close_matches(str(name), [str(n) for n in names], n=5, cutoff=0.4)
    hint = f"closest: {near}" if near else f"there are {len(names)}: {sorted(map(str, names))[:12]}"
    return InputError(f"{what}: no {noun} named {str(name)[:80]!r}; {hint}")


def _resolve(model, g, k):
    """A declaration or a CollisionGeometry as an _Item."""
    if isinstance(g, CollisionGeometry):
        return _Item(g.name, int(g.body), g.frame, KIND_CODES[g.kind], tuple(g.size), np.asarray(g.pose), False)
    if isinstance(g, PRIMITIVES):
        if g.frame == "world":
            body, Tf = -1, np.eye(4)
        elif g.frame in model.frames:
            body, Tf = model.frames[g.frame]
        else:
            raise _unknown(g.frame, list(model.frames) + ["world"], f"geometries[{k}].frame", "frame")
        name = g.name or f"{g.frame}/{g.kind}{k}"
        return _Item(name, int(body), g.frame, KIND_CODES[g.kind], tuple(g.size), np.asarray(Tf) @ g.pose,
                     body < 0)
    raise InputError(f"geometries[{k}]: expected dynamics.Sphere, Box, Capsule, Cylinder, ContactPoint or a "
                     f"CollisionGeometry, got {type(g).__name__}")


def _plane(g, k):
    n = np.array(g.normal)
    T = np.eye(4)
    # a rotation whose third column is n: the other two complete a right-handed frame
    t = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(t, n)
    x /= np.linalg.norm(x)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(n, x), n, g.offset * n
    name = g.name or f"halfspace{k}"
    return _Item(name, -1, "world", PLANE, (0.0, 0.0, 0.0), T, True)


def _items(model, geometries, world):
    """Every geometry of the scene as _Items, the model's and declared ones first, then the world's."""
    if geometries is None:
        geometries = model.collision_geometry
    geometries, world = _bounded(geometries, "geometries", MAX_GEOMETRIES), _bounded(world, "world", MAX_GEOMETRIES)
    items = [_resolve(model, g, k) for k, g in enumerate(geometries)]
    for k, g in enumerate(world):
        if isinstance(g, PLANES):
            items.append(_plane(g, k))
        elif isinstance(g, PRIMITIVES) and g.frame == "world":
            items.append(_resolve(model, g, k)._replace(world=True))
        else:
            raise InputError(f"world[{k}]: expected dynamics.Ground, HalfSpace or a primitive with frame 'world' "
                             f"(a static Box), got {type(g).__name__}"
                             f"{' on frame ' + repr(g.frame) if isinstance(g, PRIMITIVES) else ''}")
    if len(items) > MAX_GEOMETRIES:
        raise InputError(f"geometries: {len(items)} in all; at most {MAX_GEOMETRIES} are accepted")
    for it in items:
        _check_item(it)
    return _unique_names(items)


def _bounded(xs, what, limit):
    """xs as a list, refusing more than ``limit`` items before reading them all."""
    if xs is None:
        return []
    if isinstance(xs, (str, bytes)) or not hasattr(xs, "__iter__"):
        raise InputError(f"{what}: expected a list, got {type(xs).__name__}")
    if hasattr(xs, "__len__") and len(xs) > limit:
        raise InputError(f"{what}: {len(xs)} entries; at most {limit} are accepted")
    out = list(itertools.islice(iter(xs), limit + 1))
    if len(out) > limit:
        raise InputError(f"{what}: more than {limit} entries; at most {limit} are accepted")
    return out


def _check_item(it):
    size, T = np.asarray(it.size, float), np.asarray(it.T, float)
    if size.shape != (3,) or not np.all(np.isfinite(size)) or np.any(size < 0):
        raise InputError(f"geometry {it.name!r}: size must be 3 finite numbers >= 0, got {size.tolist()}")
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise InputError(f"geometry {it.name!r}: pose must be a finite 4x4 pose")


def _unique_names(items):
    seen, out = {}, []
    for it in items:
        n = seen.get(it.name, 0)
        seen[it.name] = n + 1
        out.append(it if n == 0 else it._replace(name=f"{it.name}#{n}"))
    return out


def _tree_of(model, body):
    """The kinematic tree a body belongs to: its root body if that root moves freely, else -1 (the fixed base's
    robot, the world's own links included)."""
    if body < 0:
        return -1
    parents, jtype = model.tree.parents, model.tree.jtype
    while parents[body] >= 0:
        body = int(parents[body])
    return body if jtype[body] == JOINT_FREE else -1


def _automatic(model, items, self_collision):
    """The candidate pairs of the module docstring's rules, by groups (the world's objects, each kinematic tree)
    so that the work is bounded by the pairs kept, not by all pairs of geometries."""
    world, trees = [], {}
    for k, it in enumerate(items):
        if it.world:
            world.append(k)
        else:
            trees.setdefault(_tree_of(model, it.body), []).append(k)
    groups = list(trees.values())
    count = sum(len(g) for g in groups) * len(world) + sum(len(g) * len(h) for g, h in
                                                           itertools.combinations(groups, 2))
    if count > MAX_PAIRS:
        raise InputError(f"pairs: the geometry makes {count} candidate pairs, more than {MAX_PAIRS}; list the "
                         f"pairs to check (pairs=...)")
    out = [(a, b) for g, h in itertools.combinations(groups, 2) for a in g for b in h]
    out += [(a, w) for g in groups for a in g if items[a].body >= 0 for w in world]
    if self_collision:
        out += _self_pairs(model, items, groups, MAX_PAIRS - len(out))
    return sorted((min(a, b), max(a, b)) for a, b in out)


def _self_pairs(model, items, groups, room):
    """Pairs within one kinematic tree: never two static geometries, one body, or a body and its parent."""
    parents, out = model.tree.parents, []
    if sum(len(g) * (len(g) - 1) // 2 for g in groups) > 10 * MAX_PAIRS:
        raise InputError(f"self_collision: the robot has too many geometries to pair each with each (more than "
                         f"{10 * MAX_PAIRS} pairs); list the pairs to check (pairs=...)")
    for g in groups:
        for a, b in itertools.combinations(g, 2):
            A, B = items[a].body, items[b].body
            if A == B or (A >= 0 and parents[A] == B) or (B >= 0 and parents[B] == A):
                continue  # (two static geometries are one body, -1)
            out.append((a, b))
            if len(out) > room:
                raise InputError(f"pairs: the geometry makes more than {MAX_PAIRS} candidate pairs; list the "
                                 f"pairs to check (pairs=...) or leave self_collision off")
    return out


def _matcher(model, items):
    """name -> set of item indices it matches (geometry name, frame, body's link name, 'world')."""
    index = {}
    for k, it in enumerate(items):
        keys = {it.name, it.frame, "world" if it.body < 0 else model.body_names[it.body]}
        for key in keys:
            index.setdefault(key, set()).add(k)
    return index


def _name_pairs(spec, what, index):
    """The (name, name) entries of ``exclude`` or ``pairs`` as pairs of item-index sets."""
    out = []
    for k, entry in enumerate(_bounded(spec, what, MAX_PAIRS)):
        if isinstance(entry, (str, bytes)) or not hasattr(entry, "__len__") or len(entry) != 2:
            raise InputError(f"{what}[{k}]: expected a pair of geometry, frame or link names, got {entry!r:.80}")
        sets = []
        for name in entry:
            if not isinstance(name, str) or name not in index:
                raise _unknown(name, sorted(index), f"{what}[{k}]", "geometry, frame or link")
            sets.append(index[name])
        out.append(tuple(sets))
    return out


def _filtered(model, items, self_collision, exclude, pairs):
    index = _matcher(model, items)
    if pairs is not None:
        chosen, work = set(), 0
        for k, (sa, sb) in enumerate(_name_pairs(pairs, "pairs", index)):
            work += len(sa) * len(sb)
            if work > 10 * MAX_PAIRS:
                raise InputError(f"pairs: the names up to pairs[{k}] match more than {10 * MAX_PAIRS} geometry pairs")
            for a in sa:
                for b in sb:
                    if a != b and not (items[a].body < 0 and items[b].body < 0) and items[a].body != items[b].body:
                        chosen.add((min(a, b), max(a, b)))
            if len(chosen) > MAX_PAIRS:
                raise InputError(f"pairs: they name more than {MAX_PAIRS} geometry pairs")
        candidates = sorted(chosen)
    else:
        candidates = _automatic(model, items, self_collision)
    drop = _name_pairs(exclude, "exclude", index)
    return [(a, b) for a, b in candidates
            if not any((a in sa and b in sb) or (a in sb and b in sa) for sa, sb in drop)]


def build_scene(model, geometries=None, world=(Ground(),), *, self_collision=False, exclude=(), pairs=None):
    """The :class:`Scene` of ``model``'s contact geometry and the world's objects (module docstring).

    ``geometries``: CollisionGeometry records and/or declarations (:class:`~dynamics.Sphere`, ``Box``,
    ``Capsule``, ``Cylinder``, ``ContactPoint``); None = ``model.collision_geometry``.  ``world``:
    :class:`~dynamics.Ground`, :class:`~dynamics.HalfSpace` and static primitives (frame ``"world"``).
    ``self_collision``: also pairs within one robot (never a body with itself or its parent).  ``exclude``:
    (name, name) pairs to drop; ``pairs``: the (name, name) pairs to check instead of the automatic list.
    """
    if not isinstance(self_collision, (bool, np.bool_)):
        raise InputError(f"self_collision: expected True or False, got {self_collision!r:.40}")
    items = _items(model, geometries, world)
    chosen = _filtered(model, items, bool(self_collision), exclude, pairs)
    pa, pb = [], []
    for a, b in chosen:  # each pair ordered by kind (the narrow phase's table is indexed [kind a, kind b])
        if items[a].kind > items[b].kind:
            a, b = b, a
        pa.append(a)
        pb.append(b)
    T = np.array([it.T for it in items], float).reshape(-1, 4, 4)
    kinds = np.array([it.kind for it in items], np.int64)
    size = np.array([it.size for it in items], float).reshape(-1, 3)
    return Scene(
        body=_frozen([it.body for it in items], np.int64), kind=_frozen(kinds, np.int64), size=_frozen(size),
        R=_frozen(T[:, :3, :3]), p=_frozen(T[:, :3, 3]),
        radius=_frozen([bounding_radius(k, s) for k, s in zip(kinds, size)]),
        pair_a=_frozen(pa, np.int64), pair_b=_frozen(pb, np.int64), names=tuple(it.name for it in items),
        max_contacts=int(sum(MAX_PER_PAIR[kinds[a], kinds[b]] for a, b in zip(pa, pb))))
