"""Smaller models for a scene: joints locked at given values (Pinocchio's ``buildReducedModel``).

Locking joint i at value q_i turns it into a fixed joint with placement X_i * J_i(q_i); body i is then welded
to its parent and merged exactly (mass, first moment and inertia carried into the parent frame by the
parallel-axis theorem), and its children hang from the parent with their placements composed.  A body
welded to the world (fixed base) simply leaves the model.  Frames of merged links are kept, expressed in
the body they now belong to.
"""

from dataclasses import replace

import numpy as np

from .constraints import JointCoupling, arrays, constraint_residual, with_constraints
from .errors import InputError
from .joints import KINDS, joint_matrix
from .model import BodySpec, Model, build_model


def joint_pose(model, i, qi):
    """4x4 pose of body i in its parent frame with its joint at the coordinates qi (placement * motion)."""
    return model.placements[i] @ joint_matrix(int(model.tree.jtype[i]), model.tree.axis[i], qi)


def _spec(model, i, parent, placement):
    t = model.tree
    k = t.v_idx[i]
    return BodySpec(
        name=model.body_names[i], joint_name=model.joint_names[i], joint_type=model.joint_types[i],
        parent=parent, placement=placement, axis=np.array(t.axis[i]), mass=float(t.mass[i]),
        h=np.array(t.h[i]), Io=np.array(t.Io[i]), lower=float(model.lower[k]), upper=float(model.upper[k]),
        effort=float(model.effort_limit[k]), velocity=float(model.velocity_limit[k]),
        damping=float(model.damping[k]), friction=float(model.friction[k]))


def _merge_inertia(spec, T, m, h, Io):
    """Add a rigid-body inertia (m, h, Io) given in a frame at pose T (in spec's body frame) to spec."""
    R, p = T[:3, :3], T[:3, 3]
    hR = R @ h
    spec.mass += m
    spec.h = spec.h + hR + m * p
    spec.Io = (spec.Io + R @ Io @ R.T + (2 * p @ hR + m * p @ p) * np.eye(3)
               - (np.outer(hR, p) + np.outer(p, hR) + m * np.outer(p, p)))


def lock_joints(model: Model, values: dict) -> Model:
    """A reduced model with the joints named in ``values`` frozen there and their bodies merged.

    ``values`` maps joint names to a position (a number for 1-dof joints, 7 numbers [x, y, z, qx, qy, qz, qw] for
    a floating joint, 4 numbers [qx, qy, qz, qw] for a spherical joint, 4 numbers [x, y, cos theta, sin theta]
    for a planar joint).
    The reduced model lists what was locked in ``model.summary()["locked_joints"]``.
    """
    if not isinstance(model, Model):
        raise InputError(f"model: expected a dynamics.Model, got {type(model).__name__}")
    if not isinstance(values, dict):
        raise InputError("locked: expected a mapping {joint name: value}")
    locked = {}
    for name, value in values.items():
        if name not in model.joint_names:
            raise InputError(f"locked: no movable joint named {name!r}; joints are {list(model.joint_names)}")
        i = model.joint_names.index(name)
        kind = KINDS[int(model.tree.jtype[i])]
        try:
            qi = np.atleast_1d(np.asarray(value, dtype=float)) if not isinstance(value, str) else None
        except (TypeError, ValueError):
            qi = None
        if qi is None or qi.shape != (kind.nq,) or not np.all(np.isfinite(qi)):
            layout = kind.q_layout + " " if kind.q_layout else ""
            raise InputError(f"locked[{name!r}]: expected {kind.nq} finite number{'s' if kind.nq > 1 else ''} "
                             f"{layout}(a {model.joint_types[i]} joint), got {value!r}")
        if kind.unit and np.linalg.norm(qi[kind.unit[0]:sum(kind.unit)]) < 1e-8:
            raise InputError(f"locked[{name!r}]: " + (
                "the quaternion is zero; expected a unit quaternion in the order (x, y, z, w), scalar last"
                if kind.unit[1] == 4 else "(cos theta, sin theta) is zero; expected [x, y, cos theta, sin theta] "
                "with cos^2 + sin^2 = 1"))
        locked[i] = qi

    # new_of[i] = (body it now belongs to or -1, pose of body i's frame in that body)
    new_of, specs = [], []
    for i in range(model.nbodies):
        par = int(model.parents[i])
        pbody, Tp = (-1, np.eye(4)) if par < 0 else new_of[par]
        if i in locked:
            T = Tp @ joint_pose(model, i, locked[i])
            new_of.append((pbody, T))
            if pbody >= 0:
                t = model.tree
                _merge_inertia(specs[pbody], T, t.mass[i], np.array(t.h[i]), np.array(t.Io[i]))
        else:
            specs.append(_spec(model, i, pbody, Tp @ model.placements[i]))
            new_of.append((len(specs) - 1, np.eye(4)))
    frames = {}
    for link, (b, T) in model.frames.items():
        if b < 0:
            frames[link] = (b, T)
        else:
            nb, Tb = new_of[b]
            frames[link] = (nb, Tb @ T)
    info = dict(model.info)
    info["locked_joints"] = {**info.get("locked_joints", {}),
                             **{model.joint_names[i]: (float(v[0]) if v.size == 1 else v.tolist())
                                for i, v in locked.items()}}
    info["massless_bodies"] = [s.name for s in specs if s.mass == 0.0]
    reduced = build_model(model.name, specs, floating_base=any(s.joint_type == "floating" for s in specs),
                          gravity=model.gravity, warnings=model.warnings, frames=frames, info=info)
    if model.collision_geometry:
        reduced = replace(reduced, collision_geometry=tuple(_moved(g, new_of) for g in model.collision_geometry))
    if not model.constraints:
        return reduced
    return _keep_constraints(model, reduced, {model.joint_names[i]: float(v[0]) for i, v in locked.items()
                                              if v.size == 1})


def _moved(g, new_of):
    """Collision primitive g on the body its body now belongs to (-1, the world pose, when welded to it)."""
    if g.body < 0:
        return g
    body, T = new_of[g.body]
    pose = T @ g.pose
    pose.flags.writeable = False
    return g._replace(body=body, pose=pose)


def _keep_constraints(model, reduced, locked):
    """The constraints of ``model`` on the reduced model: a coupling between two locked joints must hold at
    their values (it is dropped), one with a single locked side is refused (the other joint is then fixed
    too: lock it as well); loops stay (frames keep their names), except those whose both ends ended on one
    body: dropped when they close there, refused when they do not.  Too few free coordinates left is refused
    by with_constraints, with the rank."""
    kept = []
    for c in model.constraints:
        if not isinstance(c, JointCoupling):
            kept.append(c)
            continue
        f, l = c.follower in locked, c.leader in locked
        if f and l:
            want = c.multiplier * locked[c.leader] + c.offset
            if abs(locked[c.follower] - want) > 1e-9 * (1.0 + abs(want)):
                raise InputError(f"locked: joint {c.follower!r} follows {c.leader!r} (q = {c.multiplier:g} q_leader "
                                 f"+ {c.offset:g}), so it must be locked at {want!r}, got {locked[c.follower]!r}")
        elif f or l:
            other, value = ((c.leader, (locked[c.follower] - c.offset) / c.multiplier if c.multiplier else None)
                            if f else (c.follower, c.multiplier * locked[c.leader] + c.offset))
            at = f" at {value!r}" if value is not None else ""
            raise InputError(f"locked: joint {c.follower!r} is coupled to {c.leader!r}; locking one fixes the "
                             f"other, so lock {other!r}{at} as well")
        else:
            kept.append(c)
    return with_constraints(reduced, _drop_closed_rigid_loops(reduced, kept))


def _drop_closed_rigid_loops(reduced, constraints):
    """The constraints without the loops whose two ends the locking left on one rigid body: closed, they now
    constrain nothing (with_constraints refuses such a loop); open, they can never close (refused here)."""
    held = replace(reduced, constraints=tuple(constraints))
    C, _ = arrays(held)
    rigid = [c for c in range(len(constraints)) if C.kind[c] != 3 and C.body[c, 0] == C.body[c, 1]]
    if not rigid:
        return constraints
    phi = constraint_residual(held, held.neutral())  # constant: both ends move together
    for c in rigid:
        con = constraints[c]
        r = np.abs(phi[C.row[c]:C.row[c] + con.rows]).max()
        if r > 1e-9:
            loop = con.name or con.frame_a + "-" + con.frame_b
            raise InputError(f"locked: the joints locked leave both ends of loop {loop!r} on one rigid body "
                             f"{r:.3g} apart: the loop cannot close")
    return [con for c, con in enumerate(constraints) if c not in rigid]
