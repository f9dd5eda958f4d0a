"""The torque sources' state derivatives (core/control/derivatives.hpp) and the closed loop's
(dynamics.torque_derivatives, on the core) against central finite differences on the manifold: q moved along
dynamics.integrate(q, +-h e_k) (the tangent space), v along +-h e_k.  The torque being differenced is the
source's own evaluation in the core (``_core.source_torques``, the simulation's); the closed loop's acceleration is dynamics.forward_dynamics
under that torque plus the passive torques written out here."""

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.control.registry import release_callable
from dynamics.control.validation import make_source
from dynamics.errors import InputError
from dynamics.simulation.native import core_passive, core_source
from dynamics.torque_derivatives import _passive, _prepared
from dynamics.torques import PD, ComputedTorque, OperationalSpace, Table, Target, TaskReference
from robots import ALL_TYPES, erd, random_state, random_urdf

H = 1e-7
TOL = 1e-6


def torque(model, source, t, q, v, limits=None):
    """The torque the source applies (the core's evaluation, as the simulator's)."""
    src = make_source(model, source)
    ps = _passive(model, None, limits, 1e4, 100.0, 1e-3)
    tau = np.empty(model.nv)
    try:
        _core.source_torques(model.core, core_passive(model, ps), core_source(model, src), float(t),
                             np.asarray(q, float), np.asarray(v, float), tau)
    finally:
        if src.slot >= 0:
            release_callable(src.slot)
    return tau


def passive(model, q, v, limits=None):
    """simulate's passive torques: -d v - F tanh(v / 1e-3), Hunt-Crossley springs (k 1e4, b 100) at limits."""
    tau = -model.damping * v - model.friction * np.tanh(v / 1e-3)
    if limits == "spring":
        for i, jt in enumerate(model.joint_types):
            if jt in ("revolute", "prismatic"):
                k, kq = model.v_index[i], model.q_index[i]
                lo, up = model.lower[k], model.upper[k]
                if q[kq] < lo:
                    pen = lo - q[kq]
                    tau[k] += max(0.0, 1e4 * pen - 100.0 * pen * v[k])
                elif q[kq] > up:
                    pen = q[kq] - up
                    tau[k] -= max(0.0, 1e4 * pen + 100.0 * pen * v[k])
    return tau


def central(f, model, q, v, h=H):
    """(df/dq in the tangent space, df/dv) by central differences."""
    n = model.nv
    E = np.eye(n)
    Fq = np.array([(f(dynamics.integrate(model, q, h * e), v) - f(dynamics.integrate(model, q, -h * e), v)) / (2 * h)
                   for e in E]).T
    Fv = np.array([(f(q, v + h * e) - f(q, v - h * e)) / (2 * h) for e in E]).T
    return Fq, Fv


def rel(A, F):
    return np.abs(A - F).max() / max(np.abs(F).max(), 1.0)


def check_source(model, source, t, q, v, limits=None):
    dq, dv = dynamics.torque_source_derivatives(model, source, t, q, v, limits=limits)
    Fq, Fv = central(lambda q, v: torque(model, source, t, q, v, limits), model, q, v)
    assert dq.shape == dv.shape == (model.nv, model.nv)
    assert rel(dq, Fq) < TOL and rel(dv, Fv) < TOL, (rel(dq, Fq), rel(dv, Fv))
    return dq, dv


def check_closed_loop(model, source, t, q, v, limits=None, h=H):
    da_dq, da_dv = dynamics.closed_loop_derivatives(model, source, t, q, v, limits=limits)

    def acc(q, v):
        return dynamics.forward_dynamics(model, q, v, torque(model, source, t, q, v, limits)
                                         + passive(model, q, v, limits))
    Fq, Fv = central(acc, model, q, v, h)
    assert rel(da_dq, Fq) < TOL and rel(da_dv, Fv) < TOL, (rel(da_dq, Fq), rel(da_dv, Fv))


@pytest.fixture(scope="module")
def panda():
    return dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")


def _tree_with(types, floating, want):
    for seed in range(100):
        rng = np.random.default_rng(seed)
        model = dynamics.load_urdf(random_urdf(rng, 7, types=types, floating_joint=floating))
        if want <= set(model.joint_types):
            return model, rng
    raise AssertionError("no random tree with the joints wanted")


@pytest.fixture(scope="module")
def floating():
    """A floating base with a spherical joint under it."""
    return _tree_with(ALL_TYPES, True, {"floating", "spherical"})


@pytest.fixture(scope="module")
def multi_dof():
    """A fixed base with spherical and planar joints."""
    return _tree_with(ALL_TYPES, False, {"spherical", "planar"})


def _pd(model, rng, **kw):
    qt, vt, _ = random_state(model, rng)
    return PD(qt, rng.uniform(1, 50, model.nv), rng.uniform(1, 10, model.nv), v_target=vt,
              tau_ff=rng.normal(size=model.nv), **kw)


def test_pd_on_the_manifold(floating, multi_dof):
    for model, rng in (floating, multi_dof):
        q, v, _ = random_state(model, rng)
        src = _pd(model, rng)
        dq, dv = check_source(model, src, 0.3, q, v)
        assert np.array_equal(dv, -np.diag(src.kd))


def test_pd_panda_and_the_closed_loop(panda, floating):
    rng = np.random.default_rng(1)
    q, v, _ = random_state(panda, rng)
    src = _pd(panda, rng)
    dq, _ = check_source(panda, src, 0.0, q, v)
    assert np.array_equal(dq, -np.diag(src.kp))  # 1-dof joints: e = q_target - q
    check_closed_loop(panda, src, 0.0, q, v)
    model, rng = floating
    q, v, _ = random_state(model, rng)
    check_closed_loop(model, _pd(model, rng), 0.0, q, v)


def _computed_torque(model, rng, N=4):
    t = np.linspace(0.0, 1.0, N)
    Q = np.array([random_state(model, rng)[0] for _ in range(N)]) * 0.3
    return ComputedTorque(t, Q, rng.normal(size=(N, model.nv)), rng.normal(size=(N, model.nv)),
                          kp=rng.uniform(10, 100, model.nv), kd=rng.uniform(1, 20, model.nv))


def test_computed_torque_panda(panda):
    rng = np.random.default_rng(2)
    src = _computed_torque(panda, rng)
    q, v, _ = random_state(panda, rng)
    q = np.clip(q, panda.lower + 0.005, panda.upper - 0.005)  # off the springs' kinks
    q[0] = panda.upper[0] + 0.05  # beyond its limit: the springs' derivatives enter (the source cancels them)
    v[0] = -0.2
    for t in (0.0, 0.45, 2.0):  # a knot, inside a segment, past the end
        check_source(panda, src, t, q, v, limits="spring")
    check_closed_loop(panda, src, 0.45, q, v, limits="spring", h=1e-6)  # large accelerations: rounding at 1e-7


def test_time_only_sources_are_zero(panda):
    rng = np.random.default_rng(3)
    q, v, _ = random_state(panda, rng)
    table = Table([0.0, 1.0], rng.normal(size=(2, panda.nv)))
    for src in (None, rng.normal(size=panda.nv), table):
        dq, dv = dynamics.torque_source_derivatives(panda, src, 0.5, q, v)
        assert not dq.any() and not dv.any()
    check_closed_loop(panda, table, 0.5, q, v)


def _analytical(model, source, t, q, v):
    """Whether the source's derivative came from its analytical function in the core (not the differences)."""
    src, ps, t, q, v = _prepared(model, source, t, q, v, (None, None, 1e4, 100.0, 1e-3))
    n = model.nv
    try:
        return _core.torque_source_derivatives(model.core, core_passive(model, ps), core_source(model, src), t, q, v,
                                               np.empty((n, n)), np.empty((n, n)))
    finally:
        if src.slot >= 0:
            release_callable(src.slot)


def _pose_path():
    """A moving pose for Panda's hand: a circle, turning about three axes."""
    t = np.linspace(0.0, 1.0, 11)
    p = np.stack([0.4 + 0.1 * np.cos(3 * t), 0.1 * np.sin(3 * t), 0.5 + 0.05 * t], 1)
    R = [dynamics.spatial.rpy_to_matrix((np.pi + 0.3 * s, 0.2 * s, s)) for s in t]
    return TaskReference(t, p, orientation=R)


@pytest.mark.parametrize("case", ["position", "rows", "orientation_rows", "pose_path", "damped_springs"])
def test_operational_space_panda(panda, case):
    """The operational-space controller's analytical derivatives (core/control/operational_space_derivatives.cpp)
    against central differences of its torque: position only, two task rows, two orientation rows far from the
    target orientation, a moving pose with a posture task
    at three times (before, inside and after the reference's times), and damping with the limit springs."""
    rng = np.random.default_rng(11)
    q, v, _ = random_state(panda, rng)
    q = np.clip(q, panda.lower + 0.005, panda.upper - 0.005)  # off the springs' kinks
    v = 2.0 * rng.normal(size=panda.nv)
    limits, times = None, (0.0,)
    if case == "position":
        source = Target("panda_hand", [0.4, 0.1, 0.5], kp=100.0, kd=20.0)
    elif case == "rows":
        source = Target("panda_hand", [0.4, 0.1, 0.5], kp=[100.0, 50.0], kd=[20.0, 10.0], rows=[0, 2])
    elif case == "orientation_rows":
        source = Target("panda_hand", [0.4, 0.1, 0.5], dynamics.spatial.rpy_to_matrix((2.5, -0.4, 1.0)), kp=80.0,
                        kd=12.0, rows=[3, 5])
    elif case == "pose_path":
        source = OperationalSpace("panda_hand", _pose_path(), [80.0, 80.0, 80.0, 30.0, 30.0, 30.0], [15.0] * 6,
                                  posture=np.zeros(panda.nq), posture_kp=3.0)
        times = (-0.5, 0.37, 2.0)
    else:
        source = Target("panda_hand", [0.4, 0.1, 0.5], kp=100.0, kd=20.0, orientation=np.eye(3),
                        posture=np.zeros(panda.nq), posture_kp=5.0, damping=1e-2)
        q[3] = panda.lower[3] - 0.01  # inside a limit spring
        limits = "spring"
    for t in times:
        assert _analytical(panda, source, t, q, v)
        check_source(panda, source, t, q, v, limits)
    check_closed_loop(panda, source, times[-1], q, v, limits)


def test_operational_space_multi_dof_is_differenced(multi_dof):
    """A fixed base with spherical and planar joints (nq > nv): the controller's derivatives are differenced,
    still to the differences' accuracy."""
    model, rng = multi_dof
    q, v, _ = random_state(model, rng)
    frame = max(model.frame_names, key=lambda f: np.linalg.matrix_rank(
        dynamics.frame_jacobian(model, q, f, reference="local_world_aligned")[:3], tol=1e-3))  # a full-rank task
    source = Target(frame, dynamics.frame_placement(model, q, frame)[:3, 3] + 0.1, kp=50.0, kd=10.0)
    assert not _analytical(model, source, 0.0, q, v)
    check_source(model, source, 0.0, q, v)


def test_differenced_kinds(panda):
    """Callables have no analytical derivative: differenced, still to the finite differences' accuracy."""
    rng = np.random.default_rng(4)
    q, v, _ = random_state(panda, rng)
    K = rng.normal(size=(panda.nv, panda.nv))

    def fn(t, q, v):
        return np.sin(K @ q) + K.T @ v * t
    assert not _analytical(panda, fn, 0.7, q, v)
    check_source(panda, fn, 0.7, q, v)
    check_closed_loop(panda, fn, 0.7, q, v)


def test_bad_input_names_the_argument(panda):
    q, v = np.zeros(panda.nq), np.zeros(panda.nv)
    src = PD(q, 1.0, 1.0)
    for args, name in (((panda, PD(q[:3], 1.0, 1.0), 0.0, q, v), "source.q_target"),
                       ((panda, src, "x", q, v), "t"), ((panda, src, 0.0, q[:3], v), "q"),
                       ((panda, src, 0.0, q, v[:2]), "v"), (("panda", src, 0.0, q, v), "model")):
        for fn in (dynamics.torque_source_derivatives, dynamics.closed_loop_derivatives):
            with pytest.raises(InputError, match=name):
                fn(*args)
    with pytest.raises(InputError, match="limits"):
        dynamics.closed_loop_derivatives(panda, src, 0.0, q, v, limits="hard")
