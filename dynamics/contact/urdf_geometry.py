"""The contact geometry of a URDF: ``<collision>`` primitives and ``<contact_geometry>`` elements.

Read by ``load_urdf(..., collision=True)`` (:mod:`dynamics.urdf`), after the tree is walked: each primitive is
placed on the body its link ended up on (fixed joints merged: the link's pose in that body composed with the
``<origin>``), as a :class:`~dynamics.contact.geometry.CollisionGeometry`.  Meshes are never opened, only
counted.  ``<contact_geometry>`` is the extension element for robots whose collisions are meshes::

    <contact_geometry link="LF_FOOT" type="sphere" radius="0.03" xyz="0 0 -0.02" rpy="0 0 0" name="lf"/>

``type`` is sphere (``radius``), box (``size="x y z"``, full edges), capsule or cylinder (``radius``,
``length``, axis along z of ``rpy``), or point; ``xyz``/``rpy`` place it in the link's frame (default zero),
``name`` is optional.  A top-level element, like ``<loop>``: ROS tools skip it.
"""

import numpy as np

from ..errors import URDFError
from ..spatial import rpy_to_matrix
from .geometry import MAX_LENGTH, CollisionGeometry

#: the <collision><geometry> children read, and the ones skipped unopened
_PRIMITIVES = ("sphere", "box", "cylinder", "capsule")
_SKIPPED = ("mesh",)


def _numbers(el, attr, n, what, default=None):
    text = el.get(attr, default)
    if text is None:
        raise URDFError(f"{what}: missing attribute {attr!r}")
    try:
        x = [float(t) for t in text.split()]
    except ValueError:
        raise URDFError(f"{what}: {attr}={text[:40]!r} is not {n} number{'s' if n > 1 else ''}") from None
    if len(x) != n or not all(np.isfinite(x)):
        raise URDFError(f"{what}: {attr} must be {n} finite number{'s' if n > 1 else ''}, got {text[:40]!r}")
    if any(abs(v) > MAX_LENGTH for v in x):
        raise URDFError(f"{what}: {attr}={text[:40]!r} exceeds {MAX_LENGTH:.0e} m")
    return x


def _pose(el, what):
    """The 4x4 pose of xyz/rpy attributes of ``el`` (zero when missing)."""
    T = np.eye(4)
    if el is not None:
        T[:3, :3] = rpy_to_matrix(_numbers(el, "rpy", 3, what, "0 0 0"))
        T[:3, 3] = _numbers(el, "xyz", 3, what, "0 0 0")
    return T


def _size(kind, el, what):
    """(kind, size) of a primitive element (URDF's attributes), sizes >= 0."""
    if kind == "sphere":
        size = (_numbers(el, "radius", 1, what)[0], 0.0, 0.0)
    elif kind == "box":
        size = tuple(_numbers(el, "size", 3, what))
    elif kind in ("cylinder", "capsule"):
        size = (_numbers(el, "radius", 1, what)[0], _numbers(el, "length", 1, what)[0], 0.0)
    else:  # a point
        size = (0.0, 0.0, 0.0)
    if min(size) < 0:
        raise URDFError(f"{what}: {kind} sizes must be >= 0, got {list(size)}")
    return kind, size


def _record(name, link, frames, kind, size, T):
    body, Tl = frames[link]
    pose = np.asarray(Tl, float) @ T
    pose.flags.writeable = False
    return CollisionGeometry(name, int(body), link, kind, tuple(float(v) for v in size), pose)


def read_collisions(root, frames, warnings):
    """(CollisionGeometry records, meshes skipped) of the URDF's links and ``<contact_geometry>`` elements;
    ``frames`` maps each link to (body, pose in it) as the tree walk left it."""
    out, skipped = [], 0
    for link_el in root.findall("link"):
        link = link_el.get("name")
        for k, col in enumerate(link_el.findall("collision")):
            what = f"link {link!r} <collision> {k}"
            geom = col.find("geometry")
            shapes = [c for c in (geom if geom is not None else ()) if isinstance(c.tag, str)]
            if not shapes:
                warnings.append(f"{what}: no <geometry> shape (ignored)")
                continue
            kind = shapes[0].tag
            if kind in _SKIPPED:
                skipped += 1
                continue
            if kind not in _PRIMITIVES:
                warnings.append(f"{what}: unknown shape <{kind[:40]}> (ignored)")
                continue
            kind, size = _size(kind, shapes[0], what)
            out.append(_record(col.get("name") or f"{link}/collision{k}", link, frames, kind, size,
                               _pose(col.find("origin"), what)))
    for k, el in enumerate(root.findall("contact_geometry")):
        out.append(_extension(el, k, frames))
    return tuple(out), skipped


def _extension(el, k, frames):
    """One ``<contact_geometry>`` element (module docstring)."""
    name = el.get("name") or f"contact_geometry{k}"
    what = f"<contact_geometry name={name[:40]!r}>"
    link = el.get("link")
    if link not in frames:
        import difflib
        close = difflib.get_close_matches(str(link), [f for f in frames], n=5)
        raise URDFError(f"{what}: link={str(link)[:40]!r} is not a link of the URDF (closest: {close})")
    kind = el.get("type")
    if kind not in _PRIMITIVES + ("point",):
        raise URDFError(f"{what}: type {str(kind)[:40]!r}; expected one of {list(_PRIMITIVES + ('point',))}")
    kind, size = _size(kind, el, what)
    return _record(name, link, frames, kind, size, _pose(el, what))
