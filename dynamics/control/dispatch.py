"""The evaluation of a torque source in compiled code: one function per kind, selected at compile time by
the kind's tag (:func:`kind_tag`) so that a simulation compiles only its own kind (:func:`torque_eval`)."""

from typing import NamedTuple

import numpy as np
from numba.extending import overload

from .._numba import JIT_OPTIONS, copy_into
from ..configuration import _difference
from ..rnea import _rnea_into
from ..rnea import _workspace as rnea_workspace
from .interpolation import reference_at, segment
from .operational_space import operational_space_into, task_reference_at
from .passive import passive_torques
from .registry import torque_callable
from .sources import (CALLABLE, COMPUTED_TORQUE, CONSTANT, OPERATIONAL_SPACE, PD_KIND, TABLE_LINEAR, TABLE_ZOH,
                      ZERO)


def _computed_torque_eval(tag, src, tree, ps, t, q, v, ws, tau):
    """The computed torque (module docstring); compiled as :func:`torque_eval` for this kind."""
    nv = v.shape[0]
    qr = ws[1][0]
    vr = ws[1][1]
    ar = ws[1][2]
    reference_at(src.times, src.table, nv, t, qr, vr, ar)
    for i in range(nv):
        ar[i] += src.gains[1, i] * (vr[i] - v[i]) + src.gains[0, i] * (qr[i] - q[i])
    _rnea_into(tree, q, v, ar, ps.gravity, ps.f_ext, ws[0], tau)
    pas = ws[1][3]
    passive_torques(ps, q, v, pas)
    for i in range(nv):
        tau[i] -= pas[i]


def _operational_space_eval(tag, src, tree, ps, t, q, v, ws, tau):
    """The operational-space torques; compiled as :func:`torque_eval` for this kind."""
    x_ref = np.empty((3, 3))
    task_reference_at(src, t, x_ref)
    pas = ws[1][3]
    passive_torques(ps, q, v, pas)
    operational_space_into(src, tree, ps.gravity, ps.f_ext, t, q, v, x_ref, pas, ws[0], tau)


def _zero_torques(tag, src, tree, ps, t, q, v, ws, tau):
    for i in range(tau.shape[0]):
        tau[i] = 0.0


def _constant_torques(tag, src, tree, ps, t, q, v, ws, tau):
    copy_into(tau, src.gains[0])


def _table_torques(tag, src, tree, ps, t, q, v, ws, tau):
    """Linear or zero-order-hold interpolation of the rows of src.table (src.kind says which)."""
    times = src.times
    N = times.shape[0]
    if N == 1 or t <= times[0]:
        copy_into(tau, src.table[0])
    elif t >= times[N - 1]:
        copy_into(tau, src.table[N - 1])
    else:
        k = segment(times, t)
        if src.kind == TABLE_ZOH:
            copy_into(tau, src.table[k])
        else:
            s = (t - times[k]) / (times[k + 1] - times[k])
            for i in range(tau.shape[0]):
                tau[i] = (1 - s) * src.table[k, i] + s * src.table[k + 1, i]


def _pd_torques(tag, src, tree, ps, t, q, v, ws, tau):
    e = ws[1][0]
    _difference(tree, q, src.qref, e)
    for i in range(tau.shape[0]):
        tau[i] = src.gains[0, i] * e[i] + src.gains[1, i] * (src.gains[2, i] - v[i]) + src.gains[3, i]


def _callable_torques(tag, src, tree, ps, t, q, v, ws, tau):
    torque_callable(src.slot, t, q, v, tau)


class ZeroKind(NamedTuple):
    """The numba type of a source of kind ZERO (:func:`kind_tag`)."""


class ConstantKind(NamedTuple):
    """... of kind CONSTANT."""


class TableKind(NamedTuple):
    """... of kind TABLE_LINEAR or TABLE_ZOH."""


class PDKind(NamedTuple):
    """... of kind PD_KIND."""


class ComputedTorqueKind(NamedTuple):
    """... of kind COMPUTED_TORQUE."""


class CallableKind(NamedTuple):
    """... of kind CALLABLE."""


class OperationalSpaceKind(NamedTuple):
    """... of kind OPERATIONAL_SPACE."""


#: per kind: its tag (an empty NamedTuple class: a numba type with no data) and the function that evaluates it
_KINDS = {ZERO: (ZeroKind, _zero_torques), CONSTANT: (ConstantKind, _constant_torques),
          TABLE_LINEAR: (TableKind, _table_torques), TABLE_ZOH: (TableKind, _table_torques),
          PD_KIND: (PDKind, _pd_torques), COMPUTED_TORQUE: (ComputedTorqueKind, _computed_torque_eval),
          CALLABLE: (CallableKind, _callable_torques),
          OPERATIONAL_SPACE: (OperationalSpaceKind, _operational_space_eval)}
_EVAL = {tag: fn for tag, fn in _KINDS.values()}


def kind_tag(kind):
    """The tag of a source kind: passed with the source (the problem's ``tag`` field), its numba type selects the one
    evaluation :func:`torque_eval` compiles."""
    return _KINDS[kind][0]()


def torque_eval(tag, src, tree, ps, t, q, v, ws, tau):
    """tau = the source's applied torques at (t, q, v).  ws: (rnea workspace, 4 scratch (nv,) rows).  ``tag``
    (:func:`kind_tag`) names src's kind at compile time (compiled code only): a source compiles only its own
    kind's evaluation (not the PD's configuration difference, the tables' search, the callable's objmode
    block, the computed torque's RNEA or the operational-space controller of the others)."""
    raise NotImplementedError


@overload(torque_eval, jit_options=JIT_OPTIONS)
def _ov_torque_eval(tag, src, tree, ps, t, q, v, ws, tau):
    return _EVAL[tag.instance_class]


def source_workspace(source, nb, nv):
    """Scratch for :func:`torque_eval`: (an RNEA workspace, 4 (nv,) rows).  The RNEA workspace is None unless
    the source runs the RNEA (computed torque, operational space)."""
    uses_rnea = source.kind in (COMPUTED_TORQUE, OPERATIONAL_SPACE)
    return (rnea_workspace(nb) if uses_rnea else None, np.empty((4, nv)))
