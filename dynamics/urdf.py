"""URDF -> :class:`~dynamics.model.Model`.

The XML comes from untrusted callers, so it is parsed by a locked-down lxml parser (no DTD, no entity
expansion, no network, no huge trees, no recovery of broken XML); a document that declares a DOCTYPE is
refused outright.  Links' inertials and joints are then read from the parsed elements by the small readers
below (:class:`Link`, :class:`Joint`); visuals are never read and collisions only on request (their
primitives, not meshes), so no mesh, scene graph or any file named inside the URDF is ever opened.

Joint types: revolute, continuous, prismatic, fixed, floating, planar and spherical (:mod:`dynamics.joints`
lists what each means).

Fixed joints are merged: a link welded to its parent adds its mass, centre of mass and inertia to the
parent body exactly (parallel-axis theorem, :func:`dynamics.spatial.inertia_to_parent`).

Closed loops and coupled joints (:mod:`dynamics.constraints`).  ``<mimic joint="leader" multiplier="k"
offset="c"/>`` in joint f becomes the coupling q_f = k q_leader + c (``mimic="coupling"``, the default) or is
ignored with a warning (``mimic="independent"``, what the model did before).  A loop is declared by the
extension element, a child of ``<robot>``::

    <loop name="knee_rod" type="point|weld|revolute">
      <link_a name="thigh" xyz="0 0 -0.4" rpy="0 0 0"/>   <!-- an anchor frame fixed on a link -->
      <link_b name="rod" xyz="0 0 0.3"/>
      <axis xyz="0 1 0"/>                                 <!-- revolute only: in each anchor's frame -->
    </loop>

The two anchors coincide (point: their origins; weld: their poses; revolute: origins, and the axis as seen
by each).  Why a separate element rather than a second ``<joint>`` into the closing link: the kinematic tree
stays a valid URDF, so ROS tools, urdfdom and Pinocchio still load the file (they skip unknown top-level
elements) as its spanning tree, while a second parent makes each of them refuse it.  Plain ``<loop>`` (no
namespace prefix like Drake's ``<drake:ball_constraint>``) because the untrusted-XML parser needs no
namespace declaration for it, and one element with a ``type`` covers all three closures.

Contact geometry (``load_urdf(..., collision=True)``, :mod:`dynamics.contact.urdf_geometry`): the
``<collision>`` primitives (sphere, box, cylinder, capsule) are kept with their origins, on the body their link
was merged into; meshes are counted, never opened.  Robots whose collisions are meshes declare primitives with
the extension element, a child of ``<robot>`` as ``<loop>`` is (ROS tools skip it)::

    <contact_geometry link="LF_FOOT" type="sphere" radius="0.03" xyz="0 0 -0.02" name="lf_foot"/>
    <contact_geometry link="sole" type="box" size="0.2 0.1 0.02" xyz="0 0 -0.01" rpy="0 0 0"/>

with ``type`` sphere (radius), box (size, full edges), capsule or cylinder (radius, length; axis along the
local z after rpy) or point.
"""

import difflib
import os
import re
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from lxml import etree

from .contact.urdf_geometry import read_collisions
from .constraints import JointCoupling, PointConstraint, RevoluteConstraint, WeldConstraint, with_constraints
from .errors import DynamicsError, URDFError
from .joints import URDF_JOINT_CODES, kind_of
from .model import BodySpec, Model, build_model
from .spatial import rpy_to_matrix

#: largest URDF accepted by the library (the service applies its own, smaller limit)
MAX_URDF_BYTES = 64 * 1024 * 1024
#: inertia check: a relative violation of positive-definiteness / the triangle inequality below WARN is
#: accepted silently (round-off), below REFUSE it is accepted with a warning (real URDFs such as Talos are
#: slightly off), above REFUSE the URDF is refused unless strict_inertia=False (several published URDFs,
#: e.g. ANYmal's dummy base link or PR2's sensor mounts, are far off; Pinocchio loads them as they are).
INERTIA_WARN = 1e-9
INERTIA_REFUSE = 1e-2
#: violations smaller than this (kg m^2) are round-off in any real robot and pass silently
INERTIA_ABS_TOL = 1e-12
#: a link heavier than MAX_MASS kg, or with a principal moment above MAX_INERTIA kg m^2, is refused: a hundred
#: thousand times the heaviest machine ever built (1.4e7 kg), so only a wrong unit or a typo (1e308) gets there,
#: and the products the dynamics form from it (m g l, m a l, m l^2 w^2 with lengths, rates and accelerations up
#: to the simulation's blow-up threshold of 1e6) stay below 1e36, far from float64's overflow at 1.8e308; at
#: 1e308 the inverse dynamics overflow to inf and the other links vanish in its round-off (forward dynamics then
#: called their joints massless)
MAX_MASS = 1e12
MAX_INERTIA = 1e12
#: a body lighter than this fraction of the robot's mass gets a warning: the composite inertias of the joints
#: above it carry it below their 12th digit (float64 keeps 16), so its own motion rests on round-off; no
#: example-robot-data robot comes near (the smallest ratio there is so101's 1e-9 kg placeholder, 1.6e-9)
MASS_RATIO_WARN = 1e-12

#: a URDF with more links or joints than this is refused while parsing (a robot has tens to a few hundred)
MAX_LINKS = 10_000
#: robot, link and joint names longer than this are refused
MAX_NAME = 256

#: elements and attributes a URDF may use where the dynamics reads it; anything else there is a typo that would
#: silently change the numbers (``<mass valu="1"/>`` would be a massless link), so it gets a warning
_KNOWN_CHILDREN = {
    "link": {"inertial", "visual", "collision"},
    "inertial": {"origin", "mass", "inertia"},
    "joint": {"origin", "parent", "child", "axis", "calibration", "dynamics", "limit", "mimic",
              "safety_controller"},
}
_KNOWN_ATTRIBUTES = {
    "mass": {"value"}, "inertia": {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"}, "origin": {"xyz", "rpy"},
    "axis": {"xyz"}, "limit": {"lower", "upper", "effort", "velocity"}, "dynamics": {"damping", "friction"},
    "mimic": {"joint", "multiplier", "offset"}, "parent": {"link"}, "child": {"link"},
}

_KNOWN = tuple(URDF_JOINT_CODES) + ("fixed",)


class Inertial(NamedTuple):
    """A link's ``<inertial>`` as written: each part None when its element is missing."""
    origin: np.ndarray | None  # (4, 4) pose of the centre-of-mass frame in the link frame
    mass: float | None
    inertia: np.ndarray | None  # (3, 3) about the centre of mass, in the origin's frame


class Link(NamedTuple):
    name: str
    inertial: Inertial | None


class Limit(NamedTuple):
    """``<limit>``: each attribute None when it is missing."""
    lower: float | None
    upper: float | None
    effort: float | None
    velocity: float | None


class JointDynamics(NamedTuple):
    """``<dynamics>``: the attributes' text (None when missing); checked and converted where the body is built,
    so a malformed number gets a message naming the attribute."""
    damping: str | None
    friction: str | None


class Mimic(NamedTuple):
    joint: str | None
    multiplier: float
    offset: float


class Joint(NamedTuple):
    name: str
    type: str | None
    parent: str
    child: str
    origin: np.ndarray | None  # (4, 4) pose of the child link's frame in the parent link's frame
    axis: np.ndarray  # as written (its length is checked where it is used); (1, 0, 0) when missing
    limit: Limit | None
    dynamics: JointDynamics | None
    mimic: Mimic | None


def _optional_float(el, attr, default=None):
    text = el.get(attr)
    return default if text is None else float(text)


def _floats(text, n, what):
    values = [float(t) for t in text.split()]
    if len(values) != n:  # urdfdom refuses these too; a longer list must not lose its tail silently
        raise ValueError(f"{what}: expected {n} numbers, got {len(values)}")
    return values


def read_origin(el):
    """``<origin xyz rpy>`` (each "0 0 0" when missing) as a (4, 4) pose; None when there is no element."""
    if el is None:
        return None
    T, R = np.eye(4), np.eye(4)
    T[:3, 3] = _floats(el.get("xyz", "0 0 0"), 3, "origin xyz")
    R[:3, :3] = rpy_to_matrix(_floats(el.get("rpy", "0 0 0"), 3, "origin rpy"))
    # translation times rotation as a product, as the yourdfpy-based reader did: the same bits, zeros' signs too
    return np.dot(T, R)


def read_inertial(el):
    """``<inertial>`` (None when missing)."""
    if el is None:
        return None
    mass, inertia = el.find("mass"), el.find("inertia")
    I = None
    if inertia is not None:
        # each missing moment reads as 1 and product as 0 (the caller refuses a partial <inertia> first)
        g = {k: inertia.get(k, d) for k, d in (("ixx", 1.0), ("iyy", 1.0), ("izz", 1.0),
                                                ("ixy", 0.0), ("ixz", 0.0), ("iyz", 0.0))}
        I = np.array([[g["ixx"], g["ixy"], g["ixz"]], [g["ixy"], g["iyy"], g["iyz"]],
                      [g["ixz"], g["iyz"], g["izz"]]], dtype=np.float64)
    return Inertial(origin=read_origin(el.find("origin")),
                    mass=None if mass is None else _optional_float(mass, "value", 0.0), inertia=I)


def read_joint(el):
    """``<joint>``: its name, type, parent and child links, origin, axis, limit, dynamics and mimic.
    ``<calibration>`` and ``<safety_controller>`` are not used but their numbers must parse (as urdfdom
    requires)."""
    for tag, attrs in (("calibration", ("rising", "falling")),
                       ("safety_controller", ("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"))):
        sub = el.find(tag)
        for a in attrs if sub is not None else ():
            _optional_float(sub, a)
    ax, lim, dyn, mim = el.find("axis"), el.find("limit"), el.find("dynamics"), el.find("mimic")
    return Joint(
        name=el.get("name"), type=el.get("type"), parent=el.find("parent").get("link"),
        child=el.find("child").get("link"), origin=read_origin(el.find("origin")),
        axis=np.array([float(t) for t in (ax.get("xyz", "1 0 0") if ax is not None else "1 0 0").split()]),
        limit=None if lim is None else Limit(*(_optional_float(lim, a) for a in Limit._fields)),
        dynamics=None if dyn is None else JointDynamics(dyn.get("damping"), dyn.get("friction")),
        mimic=None if mim is None else Mimic(mim.get("joint"), _optional_float(mim, "multiplier", 1.0),
                                             _optional_float(mim, "offset", 0.0)),
    )


def _safe_parser():
    return etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, dtd_validation=False, huge_tree=False,
        recover=False, remove_comments=True, remove_pis=True, remove_blank_text=True, collect_ids=False,
    )


def _read_source(source) -> bytes:
    if isinstance(source, (bytes, bytearray, memoryview)):
        return bytes(source)
    if isinstance(source, str) and source.lstrip().startswith("<"):
        return source.encode("utf-8")
    if isinstance(source, (str, os.PathLike)):
        path = _bundled_or_path(os.fspath(source))
        if os.path.getsize(path) > MAX_URDF_BYTES:
            raise URDFError(f"URDF source: {path!r} is larger than {MAX_URDF_BYTES} bytes")
        with open(path, "rb") as fh:
            data = fh.read()
        if path.endswith(".xacro"):  # by name only: real URDFs (Talos) keep stray <xacro:...> elements that load fine
            raise URDFError(f"URDF source: {path!r} is a xacro file; run xacro first (xacro {os.path.basename(path)} "
                            "> robot.urdf) and load its output")
        return data
    raise URDFError(f"URDF source: expected a path, str or bytes, got {type(source).__name__}")


def _bundled_or_path(path: str) -> str:
    """An existing file, or the name of a bundled robot ("puma560", "planar_2r", as the CLI and the service take
    them), or an URDFError naming the closest bundled names."""
    if os.path.isfile(path):
        return path
    from .robots import names, path as robot_path  # (robots/ is installed as dynamics.robots)
    if "/" not in path and os.sep not in path:  # (a path that is not there is not a robot's name)
        try:
            return robot_path(path)
        except FileNotFoundError:
            pass
    close = difflib.get_close_matches(os.path.basename(path).removesuffix(".urdf").replace("-", "_"),
                                      names(), n=3, cutoff=0.6)
    hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else f"; bundled robots are {names()}"
    raise URDFError(f"URDF source: {path[:200]!r} is neither URDF text nor an existing file nor a bundled robot{hint}")


_DECLARATION = re.compile(rb"^\s*(<\?xml\s[^>]*?\?>)", re.S)
_VERSION = re.compile(rb"""version\s*=\s*(["'])[^"']*\1""")


def _normalise_declaration(data: bytes) -> bytes:
    """Read what urdfdom reads: whitespace before the XML declaration is dropped and the declared XML version
    (some published URDFs say "0.0") is ignored, as TinyXML does; the encoding it names is kept."""
    m = _DECLARATION.match(data)
    if m is None:
        return data
    decl = _VERSION.sub(b'version="1.0"', m.group(1), count=1)
    return decl + data[m.end():]


def _names(names, k=8):
    """At most k names for an error message (a hostile URDF may have a million)."""
    names = list(names)
    shown = ", ".join(repr(n[:40] + "..." if len(n) > 40 else n) for n in names[:k])
    return f"[{shown}{f', ... ({len(names)} in all)' if len(names) > k else ''}]"


def parse_xml(data: bytes):
    """Parse untrusted URDF bytes into an lxml element, refusing DTDs, entities and broken XML."""
    if len(data) > MAX_URDF_BYTES:
        raise URDFError(f"URDF is larger than {MAX_URDF_BYTES} bytes")
    data = _normalise_declaration(data)
    head = data[:4096].lower()
    if b"<!doctype" in head or b"<!entity" in data.lower():
        raise URDFError("URDF: DOCTYPE and ENTITY declarations are not allowed")
    try:
        root = etree.fromstring(data, parser=_safe_parser())
    except etree.XMLSyntaxError as e:
        raise URDFError(f"URDF is not well-formed XML: {e}") from None
    if root.getroottree().docinfo.doctype:
        raise URDFError("URDF: DOCTYPE declarations are not allowed")
    if root.tag != "robot":
        raise URDFError(f"URDF root element is <{str(root.tag)[:40]}>, expected <robot>")
    n_links, n_joints = len(root.findall("link")), len(root.findall("joint"))
    if max(n_links, n_joints) > MAX_LINKS:
        raise URDFError(f"URDF has {n_links} links and {n_joints} joints; at most {MAX_LINKS} of each are "
                        f"accepted")
    return root


def _check_name(kind, name):
    if len(name) > MAX_NAME:
        raise URDFError(f"{kind} name {name[:40]!r}... has {len(name)} characters; at most {MAX_NAME} are accepted")


def _likely_typo(name, known, strict):
    """Inside <inertial> (no extension uses it) every unknown name is a typo; elsewhere URDFs carry simulator
    extensions (<contact>, limit 'current', dynamics 'K'), so only names close to a known one are."""
    return strict or bool(difflib.get_close_matches(name, known, n=1, cutoff=0.8))


def _unknown_parts(el, where, warnings):
    """Warn about children and attributes that look like typos of what the dynamics reads (``<inertai>``,
    ``<mass valu=...>``, ``<limit lowr=...>``): each would silently change the numbers."""
    strict = el.tag == "inertial"
    known = _KNOWN_CHILDREN.get(el.tag, set())
    for child in el:
        tag = child.tag if isinstance(child.tag, str) else None
        if tag is None:
            continue
        if tag not in known and _likely_typo(tag, known, strict):
            warnings.append(f"{where}: unknown element <{tag[:40]}> in <{el.tag}> (ignored; expected one of "
                            f"{sorted(known)})")
        attrs = _KNOWN_ATTRIBUTES.get(tag, set())
        for a in child.attrib if tag in _KNOWN_ATTRIBUTES else ():
            if a not in attrs and _likely_typo(a, attrs, strict):
                warnings.append(f"{where}: unknown attribute {a[:40]!r} of <{tag}> (ignored; expected "
                                f"{sorted(attrs)})")
        if tag == "inertial":
            _unknown_parts(child, where, warnings)


def _finite(what, *values):
    for v in values:
        if not np.all(np.isfinite(np.asarray(v, dtype=float))):
            raise URDFError(f"{what}: non-finite number")


def _check_inertia(link, mass, I, warnings, strict):
    """Refuse a negative mass; refuse (strict) or warn about an inertia no rigid body can have."""
    if mass < 0:
        raise URDFError(f"link {link!r}: negative mass {mass}")
    if mass > MAX_MASS:
        raise URDFError(f"link {link!r}: mass {mass:.3g} kg exceeds {MAX_MASS:.0e} kg, more than float64 dynamics "
                        f"can carry next to the other links (and more than any machine weighs); check the units")
    scale = float(np.abs(I).max())
    if scale > MAX_INERTIA:  # scaled first: the eigenvalues of a 1e308 matrix overflow
        moment = scale * float(np.abs(np.linalg.eigvalsh(I / scale)).max())
        raise URDFError(f"link {link!r}: inertia: principal moment {moment:.3g} kg m^2 exceeds {MAX_INERTIA:.0e} "
                        f"kg m^2, more than float64 dynamics can carry next to the other links; check the units")
    if not np.allclose(I, I.T):
        raise URDFError(f"link {link!r}: inertia matrix is not symmetric")
    ev = np.linalg.eigvalsh(I)
    neg = max(0.0, -ev[0])
    tri = max(0.0, ev[2] - ev[0] - ev[1])  # principal moments must obey I3 <= I1 + I2
    bad = max(neg, tri)
    rel = bad / max(abs(np.trace(I)), 1e-300)
    if bad <= INERTIA_ABS_TOL or rel <= INERTIA_WARN:
        return
    what = "is not positive semidefinite" if neg >= tri else "violates the triangle inequality"
    msg = (f"link {link!r}: inertia {what} (principal moments {np.array2string(ev, precision=4)}, "
           f"relative violation {rel:.1e})")
    if strict and rel > INERTIA_REFUSE:
        raise URDFError(msg + "; fix the URDF, or load it with strict_inertia=False to accept it with a warning")
    warnings.append(msg + "; used as is")


def _check_mass_ratios(bodies, warnings):
    """Warn about bodies whose mass is lost in the round-off of the robot's (:data:`MASS_RATIO_WARN`)."""
    total = sum(b.mass for b in bodies)
    for b in bodies:
        if 0.0 < b.mass < MASS_RATIO_WARN * total:
            warnings.append(f"link {b.name!r}: mass {b.mass:.3g} kg is {b.mass / total:.3g} of the robot's "
                            f"{total:.3g} kg, below {MASS_RATIO_WARN:.0e}: its motion rests on the round-off of the "
                            f"rest (float64 keeps 16 digits), so the joint moving it may be found singular; check "
                            f"the units")


def _origin(T, what):
    T = np.eye(4) if T is None else np.asarray(T, float)
    if T.shape != (4, 4):
        raise URDFError(f"{what} origin: expected xyz and rpy with 3 numbers each")
    _finite(what + " origin", T)
    return T


def load_urdf(source, *, floating_base: bool = False, strict_inertia: bool = True, mimic: str = "coupling",
              collision: bool = False) -> Model:
    """Build a :class:`~dynamics.model.Model` from a URDF path or URDF text (str or bytes).

    ``floating_base=True`` gives the root link a free joint ("root_joint"): q = [x, y, z, qx, qy, qz, qw, ...],
    v = [linear, angular velocity in the base frame, ...].  A URDF ``floating`` joint means the same.
    ``planar`` joints (q = [x, y, cos theta, sin theta], v = [vx, vy, wz] in the child frame, the plane normal to
    the joint's axis) and ``spherical`` joints (an extension pybullet reads: q = [qx, qy, qz, qw], v = the
    angular velocity in the child frame) follow Pinocchio's JointModelPlanar and JointModelSpherical
    (:mod:`dynamics.joints`); they have no position limits or damping.
    Raises :class:`~dynamics.URDFError` naming the link or joint when the URDF cannot describe a tree of
    rigid bodies.  ``strict_inertia=False`` accepts inertias that violate positive-definiteness or the
    triangle inequality by more than 1 % (with a warning in ``model.warnings``) instead of refusing them.
    ``mimic="coupling"`` (default) turns each ``<mimic>`` into a :class:`~dynamics.JointCoupling` constraint
    (the follower keeps its coordinate, ``model.constraints`` ties it to the leader); ``mimic="independent"``
    leaves mimic joints free, with a warning.  ``<loop>`` elements (module docstring) become constraints too.
    ``collision=True`` keeps the ``<collision>`` primitives (sphere, box, cylinder, capsule) and the
    ``<contact_geometry>`` elements (module docstring) in ``model.collision_geometry``, each on the body its link
    was merged into; meshes are skipped unopened and counted in ``model.info``.
    """
    if not isinstance(collision, (bool, np.bool_)):
        raise URDFError(f"collision: expected True or False, got {collision!r:.40}")
    if mimic not in ("coupling", "independent"):
        raise URDFError(f"mimic: expected 'coupling' or 'independent', got {mimic!r}")
    root = parse_xml(_read_source(source))
    warnings = []
    name = root.get("name") or "robot"
    _check_name("robot", name)
    links = _read_links(root, warnings)
    joints = _read_joints(root, warnings)
    parent_joint, children, root_link = _tree(links, joints)
    bodies, frames, merged_fixed, couplings = _walk(links, children, root_link, floating_base, mimic,
                                                    strict_inertia, warnings)
    _check_mass_ratios(bodies, warnings)
    info = {
        "urdf_links": len(links),
        "urdf_joints": len(joints),
        "fixed_joints_merged": merged_fixed,
        "links_pruned": _pruned(links, children, parent_joint, frames, root_link),
        "massless_bodies": [b.name for b in bodies if b.mass == 0.0],
        "locked_joints": {},
        "meshes_loaded": 0,
    }
    geometry = ()
    if collision:
        geometry, skipped = read_collisions(root, frames, warnings)
        info.update(collision_primitives=len(geometry), collision_meshes_skipped=skipped)
    model = build_model(name, bodies, floating_base=floating_base or any(
        b.joint_type == "floating" for b in bodies), warnings=warnings, frames=frames, info=info)
    if geometry:
        model = replace(model, collision_geometry=geometry)
    constraints = _couplings(couplings, model) + _loops(root, links)
    if not constraints:
        return model
    try:
        return with_constraints(model, constraints)
    except DynamicsError as e:
        raise URDFError(f"URDF constraints: {e}") from None


def _read_links(root, warnings) -> dict:
    """The <link> elements by name, their inertials read (visuals and collisions, meshes, are never parsed)."""
    links = {}
    for el in root.findall("link"):
        lname = el.get("name")
        if not lname:
            raise URDFError("a <link> has no name attribute")
        _check_name("link", lname)
        if lname in links:
            raise URDFError(f"link {lname!r} is defined twice")
        _unknown_parts(el, f"link {lname!r}", warnings)
        mass = el.find("inertial/mass")
        if mass is not None and mass.get("value") is None:
            raise URDFError(f"link {lname!r}: <mass> has no value attribute (expected <mass value=\"...\"/>)")
        inertia = el.find("inertial/inertia")
        if inertia is not None:
            missing = [k for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz") if inertia.get(k) is None]
            if missing:
                raise URDFError(f"link {lname!r}: <inertia> is missing {missing}")
        try:
            # inertial only: visuals and collisions (meshes) mean nothing to the dynamics and are not parsed
            links[lname] = Link(name=lname, inertial=read_inertial(el.find("inertial")))
        except Exception as e:  # whatever float() or numpy raise on a malformed number
            raise URDFError(f"link {lname!r}: cannot read it ({e})") from None
    if not links:
        raise URDFError("URDF has no <link>")
    return links


def _read_joints(root, warnings) -> list:
    """The <joint> elements in document order, each checked for a name, a known type, a parent and a child."""
    joints, seen = [], set()
    for el in root.findall("joint"):
        jname = el.get("name")
        if not jname:
            raise URDFError("a <joint> has no name attribute")
        _check_name("joint", jname)
        if jname in seen:
            raise URDFError(f"joint {jname!r} is defined twice")
        seen.add(jname)
        _unknown_parts(el, f"joint {jname!r}", warnings)
        jtype = el.get("type")
        if jtype not in _KNOWN:
            raise URDFError(f"joint {jname!r}: unknown type {str(jtype)[:40]!r}, expected one of {list(_KNOWN)}")
        for tag in ("parent", "child"):
            sub = el.find(tag)
            if sub is None or not sub.get("link"):
                raise URDFError(f"joint {jname!r}: missing <{tag} link=...>")
        try:
            joints.append(read_joint(el))
        except Exception as e:
            raise URDFError(f"joint {jname!r}: cannot read it ({e})") from None
    return joints


def _tree(links, joints):
    """(parent joint of each link, child joints of each link, the root link): one tree, or a URDFError."""
    parent_joint, children = {}, {n: [] for n in links}
    for j in joints:
        for role, lname in (("parent", j.parent), ("child", j.child)):
            if lname not in links:
                raise URDFError(f"joint {j.name!r}: unknown {role} link {lname!r}")
        if j.child in parent_joint:
            raise URDFError(f"link {j.child!r} has two parents (joints {parent_joint[j.child].name!r} "
                            f"and {j.name!r})")
        parent_joint[j.child] = j
        children[j.parent].append(j)
    roots = [n for n in links if n not in parent_joint]
    if not roots:
        raise URDFError("URDF kinematic graph has a cycle: every link has a parent")
    if len(roots) > 1:
        raise URDFError(f"URDF has more than one root link: {_names(roots)}; expected one tree")
    return parent_joint, children, roots[0]


def _walk(links, children, root_link, floating_base, mimic, strict_inertia, warnings):
    """Walk the tree depth first from the root, children in document order: one body per movable joint, fixed
    joints merged into their parent body. (bodies, frames {name: (body, pose in it)}, merged fixed joints, the
    mimic joints to couple)."""
    bodies, frames = [], {}
    merged_fixed, couplings = [], []
    if floating_base:
        bodies.append(BodySpec(name=root_link, joint_name="root_joint", joint_type="floating", parent=-1,
                               placement=np.eye(4), axis=np.zeros(3)))
        frames[_joint_frame("root_joint", links)] = (0, np.eye(4))
    root_body = 0 if floating_base else -1
    # stack of (link, joint into it or None, body of the joint's parent link, joint pose in that body)
    stack = [(root_link, None, root_body, np.eye(4))]
    visited = 0
    while stack:
        lname, j, body, T = stack.pop()
        visited += 1
        if j is not None and j.type != "fixed":
            bodies.append(_movable_body(j, body, T, warnings))
            body, T = len(bodies) - 1, np.eye(4)
        if j is not None:  # a joint's frame is its child link's frame (URDF)
            frames[_joint_frame(j.name, links)] = (body, T)
        frames[lname] = (body, T)
        _add_link_inertia(links[lname], body, T, bodies, warnings, strict_inertia)
        for j in reversed(children[lname]):  # reversed: the first child is popped first
            J = _origin(j.origin, f"joint {j.name!r}")
            if j.type == "fixed":
                merged_fixed.append(j.name)
            elif j.type == "floating" and floating_base and lname == root_link:
                raise URDFError(f"joint {j.name!r}: the URDF already has a floating joint; load it with "
                                f"floating_base=False")
            elif j.mimic is not None and mimic == "independent":
                warnings.append(f"joint {j.name!r} mimics {j.mimic.joint!r}; it is treated as an independent "
                                f"joint (mimic='independent')")
            elif j.mimic is not None:
                couplings.append(j)
            stack.append((j.child, j, body, T @ J))
    if visited != len(links):
        lost = sorted(set(links) - set(frames))
        raise URDFError(f"URDF kinematic graph has a cycle through links {_names(lost)}")
    return bodies, frames, merged_fixed, couplings


def _pruned(links, children, parent_joint, frames, root_link):
    """Links that carry no mass and have no moving joint below them: dropped (kept as bare frames)."""
    moving_below = {}
    for lname in reversed([n for n in frames if n in links]):  # depth-first order: children after parents
        moving_below[lname] = any(j.type != "fixed" or moving_below[j.child] for j in children[lname])
    return [n for n in frames if n in links and n != root_link and parent_joint[n].type == "fixed"
            and not moving_below[n] and _massless(links[n])]


def _couplings(joints, model):
    """JointCoupling of each mimic joint; the leader must be a movable joint of the model."""
    out = []
    for j in joints:
        leader = j.mimic.joint
        if leader not in model.joint_names:
            close = difflib.get_close_matches(str(leader), model.joint_names, n=5)
            raise URDFError(f"joint {j.name!r}: <mimic joint={str(leader)[:40]!r}> names no movable joint of "
                            f"the model (closest: {close}); load with mimic='independent' to ignore mimics")
        try:
            out.append(JointCoupling(j.name, leader, float(j.mimic.multiplier), float(j.mimic.offset)))
        except (DynamicsError, TypeError) as e:
            raise URDFError(f"joint {j.name!r}: <mimic>: {e}") from None
    return out


def _numbers(el, attr, what, default="0 0 0"):
    try:
        x = np.array([float(t) for t in (el.get(attr) or default).split()])
    except ValueError:
        raise URDFError(f"{what}: {attr}={el.get(attr)[:40]!r} is not 3 numbers") from None
    if x.shape != (3,) or not np.all(np.isfinite(x)):
        raise URDFError(f"{what}: {attr} must be 3 finite numbers, got {el.get(attr)!r:.40}")
    return x


def _loops(root, links):
    """The constraints of the ``<loop>`` elements (module docstring)."""
    out = []
    for k, el in enumerate(root.findall("loop")):
        lname = el.get("name") or f"loop{k}"
        _check_name("loop", lname)
        what = f"<loop name={lname!r}>"
        kind = el.get("type")
        if kind not in ("point", "weld", "revolute"):
            raise URDFError(f"{what}: type {str(kind)[:40]!r}; expected 'point', 'weld' or 'revolute'")
        anchors = []
        for tag in ("link_a", "link_b"):
            sub = el.find(tag)
            if sub is None or not sub.get("name"):
                raise URDFError(f"{what}: missing <{tag} name=\"...\"/>")
            link = sub.get("name")
            if link not in links:
                close = difflib.get_close_matches(link, list(links), n=5)
                raise URDFError(f"{what}: <{tag}> names unknown link {link[:40]!r} (closest: {close})")
            T = np.eye(4)
            T[:3, :3] = rpy_to_matrix(_numbers(sub, "rpy", what))
            T[:3, 3] = _numbers(sub, "xyz", what)
            anchors.append((link, T))
        (la, Ta), (lb, Tb) = anchors
        if kind == "point":
            out.append(PointConstraint(la, lb, Ta[:3, 3], Tb[:3, 3], name=lname))
        elif kind == "weld":
            out.append(WeldConstraint(la, lb, Ta @ np.linalg.inv(Tb), name=lname))
        else:
            ax = el.find("axis")
            if ax is None:
                raise URDFError(f"{what}: a revolute loop needs <axis xyz=\"...\"/>")
            u = _numbers(ax, "xyz", what)
            if np.linalg.norm(u) < 1e-12:
                raise URDFError(f"{what}: the axis is zero")
            out.append(RevoluteConstraint(la, lb, Ta[:3, :3] @ u, Ta[:3, 3], Tb[:3, 3], Tb[:3, :3] @ u, name=lname))
    return out


def _joint_frame(name, links):
    """A joint's frame name: its own, or ``joint:NAME`` when a link has that name (the link keeps it)."""
    return "joint:" + name if name in links else name


def _massless(link):
    i = link.inertial
    return i is None or (not i.mass and (i.inertia is None or not np.any(np.asarray(i.inertia, dtype=float))))


def _movable_body(j, parent_body, placement, warnings):
    what = f"joint {j.name!r}"
    axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), float)
    if axis.shape != (3,):
        raise URDFError(f"{what}: axis must have 3 numbers, got {axis.size}")
    _finite(what + " axis", axis)
    kind = kind_of(j.type)
    if kind.axis:
        big = np.max(np.abs(axis))
        if big < 1e-12:
            raise URDFError(f"{what}: joint axis is zero" + (" (a planar joint's axis is the normal of its plane)"
                                                             if j.type == "planar" else ""))
        axis = axis / big  # scaled first: (1e300, 1e300, 1e300) would overflow the norm to inf
        axis = axis / np.linalg.norm(axis)
    else:  # a free or spherical joint has no axis
        axis = np.zeros(3)
    if j.type == "planar" and not np.array_equal(axis, [0.0, 0.0, 1.0]):
        shown = ", ".join(f"{x:.6g}" for x in axis)
        warnings.append(f"{what}: a planar joint moves in the plane normal to its axis ({shown}) (the URDF default "
                        f"is (1, 0, 0)); Pinocchio's URDF parser always takes z")
    spec = BodySpec(name=j.child, joint_name=j.name, joint_type=j.type, parent=parent_body,
                    placement=placement, axis=axis)
    if j.type in ("revolute", "prismatic") and j.limit is not None:
        lo = -np.inf if j.limit.lower is None else float(j.limit.lower)
        hi = np.inf if j.limit.upper is None else float(j.limit.upper)
        if np.isnan(lo) or np.isnan(hi):
            raise URDFError(f"{what}: limit lower/upper is not a number (got {lo}, {hi})")
        if lo > hi:  # urdfdom loads these; published URDFs use them to mean "no limit"
            warnings.append(f"{what}: lower limit {lo} is above upper limit {hi}; the joint is treated as "
                            f"unlimited")
            lo, hi = -np.inf, np.inf
        spec.lower, spec.upper = lo, hi
    if kind.limited and j.limit is not None:
        for attr in ("effort", "velocity"):
            val = getattr(j.limit, attr)
            if val is not None:
                if not np.isfinite(val) or val < 0:
                    raise URDFError(f"{what}: limit {attr} must be a finite number >= 0, got {val}")
                setattr(spec, attr, float(val))
    if j.dynamics is not None:
        for attr in ("damping", "friction"):
            val = getattr(j.dynamics, attr)
            if val is not None:
                try:
                    val = float(val)
                except ValueError:
                    raise URDFError(f"{what}: dynamics {attr} {val!r} is not a number") from None
                if not np.isfinite(val) or val < 0:
                    raise URDFError(f"{what}: dynamics {attr} must be a finite number >= 0, got {val}")
                setattr(spec, attr, float(val))
    return spec


def _add_link_inertia(link, body, T, bodies, warnings, strict):
    """Add the link's inertial to its body; links welded to the world (body -1) only get checked."""
    inertial = link.inertial
    if inertial is None:
        return
    what = f"link {link.name!r}"
    m = float(inertial.mass or 0.0)
    Ic = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=float)
    _finite(what + " mass", m)
    _finite(what + " inertia", Ic)
    O = _origin(inertial.origin, what + " inertial")
    _check_inertia(link.name, m, Ic, warnings, strict)
    if body < 0 or (m == 0.0 and not Ic.any()):
        return
    R = T[:3, :3] @ O[:3, :3]
    c = T[:3, :3] @ O[:3, 3] + T[:3, 3]
    b = bodies[body]
    b.mass += m
    b.h = b.h + m * c
    b.Io = b.Io + R @ Ic @ R.T + m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
