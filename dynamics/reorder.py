"""Joint order and coordinate conventions of other tools, mapped onto ours.

Our joints are ordered depth first from the root, children in document order (``model.joint_names``).
Pinocchio's URDF parser orders branches differently (Talos: ``root_joint, leg_left_1_joint, ...`` where we
have ``root_joint, torso_1_joint, ...``) and gives each continuous joint two configuration coordinates
(cos theta, sin theta) where we give one angle.  A vector copied from another tool without this mapping gives
silently wrong numbers.

    q_ours = reorder(model, q_pin, pin_names, kind="pinocchio_q")
    v_ours = reorder(model, v_pin, pin_names, kind="v")
    tau_pin = reorder(model, tau_ours, pin_names, kind="v", inverse=True)

``names`` lists the movable joints in the other tool's order (for Pinocchio: ``list(pin_model.names)[1:]``);
every joint of ours must appear exactly once, and no other name.
"""

import numpy as np

from .checks import check_model
from .errors import InputError, closest
from .joints import kind_of

KINDS = ("q", "v", "pinocchio_q")


def _their_sizes(model, kind):
    """Per joint of ours: its size in the other tool's vector."""
    if kind == "v":
        return [int(n) for n in model.nv_joint]
    pin = kind == "pinocchio_q"
    # Pinocchio stores a continuous joint as (cos, sin): its one fact that is not ours
    return [2 if (t == "continuous" and pin) else kind_of(t).nq for t in model.joint_types]


def _order(model, names):
    names = [str(n) for n in names]
    ours = set(model.joint_names)
    unknown = [n for n in names if n not in ours]
    if unknown:
        raise closest(unknown[0], model.joint_names, "names")
    missing = [n for n in model.joint_names if n not in names]
    if missing or len(names) != len(set(names)):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise InputError(f"names: every movable joint must appear exactly once; missing {missing[:12]}"
                         + (f", repeated {twice[:12]}" if twice else ""))
    return [model.joint_names.index(n) for n in names]


def reorder(model, x, names, kind="q", *, inverse=False):
    """Map ``x`` given in the joint order ``names`` (another tool's) into ours; ``inverse=True`` maps ours
    into theirs.  ``kind``: "q" (our coordinates, another order), "v" (velocities, accelerations, torques)
    or "pinocchio_q" (a Pinocchio configuration: continuous joints as (cos, sin)).  x: (n,) or (B, n)."""
    check_model(model)
    if kind not in KINDS:
        raise InputError(f"kind: expected one of {list(KINDS)}, got {kind!r}")
    order = _order(model, names)
    sizes = _their_sizes(model, kind)
    ours_start = model.v_index if kind == "v" else model.q_index
    ours_size = _their_sizes(model, "v" if kind == "v" else "q")
    n_theirs = sum(sizes)
    n_ours = model.nv if kind == "v" else model.nq
    X = np.asarray(x)
    if X.dtype.kind not in "fiu":
        raise InputError(f"x: expected real numbers, got an array of {X.dtype.kind!r} kind")
    n_in = n_ours if inverse else n_theirs
    if X.shape[-1:] != (n_in,) or X.ndim not in (1, 2):
        raise InputError(f"x: expected shape ({n_in},) or (B, {n_in}) for kind={kind!r}, got {X.shape}")
    X = X.astype(float)
    out = np.empty(X.shape[:-1] + (n_theirs if inverse else n_ours,))
    k = 0
    for i in order:
        o, n_o, n_t = int(ours_start[i]), ours_size[i], sizes[i]
        theirs, ours = slice(k, k + n_t), slice(o, o + n_o)
        if n_t == 2 and n_o == 1:  # a continuous joint in Pinocchio: (cos, sin) <-> angle
            if inverse:
                out[..., k], out[..., k + 1] = np.cos(X[..., o]), np.sin(X[..., o])
            else:
                out[..., o] = np.arctan2(X[..., k + 1], X[..., k])
        elif inverse:
            out[..., theirs] = X[..., ours]
        else:
            out[..., ours] = X[..., theirs]
        k += n_t
    return out
