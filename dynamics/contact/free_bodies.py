"""Free bodies: a ball or a box (or any primitive) the robot can push, hold and drop.

:func:`add_free_body` returns a new model with one more root body on a free joint (Featherstone's 6-dof
joint, :mod:`dynamics.joints`): its seven coordinates come last in q, ``[x, y, z, qx, qy, qz, qw]`` = the
body frame's world position and orientation (the joint's placement is the identity), and its six last in v,
``[linear, angular]`` in the body frame, as a floating base's.  The body's inertia is the solid's (uniform
density over the geometry) unless ``inertia`` is given, and its geometry is appended to
``model.collision_geometry``, so :func:`dynamics.contact.scene.build_scene` pairs it with the robot and the
world (two kinematic trees: always checked, with or without self-collision).  A URDF link on a ``floating``
joint is the same thing, read by :func:`dynamics.load_urdf`.
"""

from dataclasses import replace

import numpy as np

from ..constraints import with_constraints
from ..errors import InputError
from ..model import BodySpec, Model, build_model
from .geometry import Box, Capsule, CollisionGeometry, Cylinder, Sphere

#: the solids a free body can be made of (a ContactPoint has no volume, hence no inertia of its own)
SOLIDS = (Sphere, Box, Capsule, Cylinder)


def solid_inertia(geometry, mass):
    """Rotational inertia (3x3) of a uniform solid ``geometry`` of ``mass`` about its centre, in its own axes."""
    if isinstance(geometry, Sphere):
        return 0.4 * mass * geometry.radius ** 2 * np.eye(3)
    if isinstance(geometry, Box):
        x, y, z = np.square(geometry.size)
        return mass / 12.0 * np.diag([y + z, x + z, x + y])
    r, L = geometry.radius, geometry.length
    if isinstance(geometry, Cylinder):
        return np.diag([mass * (3 * r * r + L * L) / 12, mass * (3 * r * r + L * L) / 12, mass * r * r / 2])
    # a capsule: a cylinder and two hemispheres sharing the mass by volume; each hemisphere's centre of mass is
    # 3 r / 8 from its flat face, so about the capsule's centre it adds m_h (2/5 r^2 + L^2/4 + 3 L r / 8)
    vc, vh = np.pi * r * r * L, 4.0 / 3.0 * np.pi * r ** 3
    mc, mh = mass * vc / (vc + vh), mass * vh / (vc + vh)
    axial = mc * r * r / 2 + mh * 0.4 * r * r
    lateral = mc * (L * L / 12 + r * r / 4) + mh * (0.4 * r * r + L * L / 4 + 3 * L * r / 8)
    return np.diag([lateral, lateral, axial])


def _mass(mass):
    if isinstance(mass, bool) or not isinstance(mass, (int, float, np.integer, np.floating)) \
            or not np.isfinite(mass) or not 0 < mass <= 1e12:
        raise InputError(f"mass: expected a finite number in (0, 1e12] (kg), got {mass!r:.40}")
    return float(mass)


def _inertia(inertia, geometry, mass):
    """Io about the body origin (3x3) and h = m c from the solid's, or from ``inertia`` (3x3 about the centre of
    mass, the geometry's centre, in the body frame)."""
    T = geometry.pose
    R, c = T[:3, :3], T[:3, 3]
    if inertia is None:
        Ic = R @ solid_inertia(geometry, mass) @ R.T
    else:
        try:
            Ic = np.array(inertia, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"inertia: expected a 3x3 array of numbers, got {type(inertia).__name__}") from None
        if Ic.shape != (3, 3) or not np.all(np.isfinite(Ic)) or not np.allclose(Ic, Ic.T):
            raise InputError(f"inertia: expected a finite symmetric 3x3 matrix (kg m^2), got shape {Ic.shape}")
        ev = np.linalg.eigvalsh(Ic)
        if ev[0] <= 0 or ev[2] > ev[0] + ev[1] + 1e-12 * ev[2]:
            raise InputError(f"inertia: principal moments {ev.tolist()} must be > 0 and obey the triangle "
                             f"inequality (I3 <= I1 + I2)")
    return Ic + mass * (np.dot(c, c) * np.eye(3) - np.outer(c, c)), mass * c


def _specs(model):
    """The model's bodies as BodySpecs (to rebuild it with one more)."""
    t = model.tree
    out = []
    for i in range(model.nbodies):
        k = t.v_idx[i]
        out.append(BodySpec(
            name=model.body_names[i], joint_name=model.joint_names[i], joint_type=model.joint_types[i],
            parent=int(t.parents[i]), placement=model.placements[i], axis=np.array(t.axis[i]),
            mass=float(t.mass[i]), h=np.array(t.h[i]), Io=np.array(t.Io[i]), lower=float(model.lower[k]),
            upper=float(model.upper[k]), effort=float(model.effort_limit[k]),
            velocity=float(model.velocity_limit[k]), damping=float(model.damping[k]),
            friction=float(model.friction[k])))
    return out


def add_free_body(model: Model, name: str, geometry, mass: float, *, inertia=None) -> Model:
    """A new model: ``model`` plus a free rigid body ``name`` of ``mass`` (kg) shaped as ``geometry``.

    ``geometry``: a :class:`~dynamics.Sphere`, :class:`~dynamics.Box`, :class:`~dynamics.Capsule` or
    :class:`~dynamics.Cylinder` declared on the frame ``name`` (its offset or pose places it in the body
    frame), e.g. ``add_free_body(model, "ball", dynamics.Sphere("ball", 0.05), 0.2)``.  ``inertia``: the 3x3
    rotational inertia about the centre of mass (the geometry's centre), body frame; default the uniform
    solid's.  The body's 7 coordinates come last in q (its world position, then its orientation as a unit
    quaternion x, y, z, w) and its 6 last in v (linear, angular velocity in the body frame); the frames
    ``name`` (the body) and ``name + "_joint"`` are added.
    """
    if not isinstance(model, Model):
        raise InputError(f"model: expected a dynamics.Model, got {type(model).__name__}")
    if not isinstance(name, str) or not name or len(name) > 256:
        raise InputError(f"name: expected a non-empty str of at most 256 characters, got {name!r:.60}")
    joint = name + "_joint"
    taken = [n for n in (name, joint) if n in model.frames or n in model.joint_names or n in model.body_names]
    if taken:
        raise InputError(f"name: the model already has a frame, body or joint named {taken[0]!r}")
    if not isinstance(geometry, SOLIDS):
        raise InputError(f"geometry: expected dynamics.Sphere, Box, Capsule or Cylinder, got "
                         f"{type(geometry).__name__}")
    if geometry.frame != name:
        raise InputError(f"geometry.frame: a free body's geometry is declared on the body's own frame {name!r}, "
                         f"got {geometry.frame!r}")
    mass = _mass(mass)
    Io, h = _inertia(inertia, geometry, mass)
    nb = model.nbodies
    specs = _specs(model) + [BodySpec(name=name, joint_name=joint, joint_type="floating", parent=-1,
                                      placement=np.eye(4), axis=np.zeros(3), mass=mass, h=h, Io=Io)]
    frames = {**model.frames, joint: (nb, np.eye(4)), name: (nb, np.eye(4))}
    info = dict(model.info)
    info["free_bodies"] = [*info.get("free_bodies", []), name]
    out = build_model(model.name, specs, floating_base=True, gravity=model.gravity, warnings=model.warnings,
                      frames=frames, info=info)
    pose = np.array(geometry.pose)
    pose.flags.writeable = False
    record = CollisionGeometry(geometry.name or f"{name}/{geometry.kind}", nb, name, geometry.kind,
                               tuple(geometry.size), pose)
    out = replace(out, collision_geometry=tuple(model.collision_geometry) + (record,))
    if model.constraints:
        out = with_constraints(out, model.constraints)
    return out
