"""The core's constraints (core/constraints.cpp, core/constrained_dynamics.cpp) called directly through the
extension with what no public function passes: wrong shapes, dtypes, non-contiguous arrays, indices out of range,
non-finite values, constraints built for another model.  A clear error or None, never a crash or a read out of
bounds; and the public functions on the same inputs name the argument (as tests/test_core_bounds.py does for the
tree algorithms)."""

import os

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.constraints import arrays, core_constraints
from robots import OUR_ROBOTS


@pytest.fixture(scope="module", params=["four_bar.urdf", "stewart_platform.urdf"])
def model(request):
    return dynamics.load_urdf(os.path.join(OUR_ROBOTS, request.param))


def _args(model):
    C, m = arrays(model)
    return [model.core, C.kind, C.row, C.body, np.ascontiguousarray(C.R), np.ascontiguousarray(C.p), C.idx,
            np.ascontiguousarray(C.coef), m]


def test_constraints_built_from_inconsistent_arrays_are_refused(model):
    args = _args(model)
    assert _core.Constraints(*args).m == args[-1]
    nc = args[1].shape[0]

    def with_(k, value):
        a = list(args)
        a[k] = value
        return a

    bad = [
        with_(-1, args[-1] + 1),                                   # m is not the sum of the rows
        with_(-1, -1),
        with_(1, np.full(nc, 7, np.int64)),                        # an unknown kind
        with_(2, args[2] + 1),                                     # rows not consecutive
        with_(3, np.full((nc, 2), model.nbodies, np.int64)),       # a body out of range
        with_(3, np.full((nc, 2), -5, np.int64)),
        with_(3, args[3][:, :1].copy()),                           # body (nc, 1)
        with_(4, args[4][:-1].copy() if nc > 1 else np.zeros((0, 2, 3, 3))),  # R with a row less
        with_(4, np.full_like(args[4], np.nan)),                   # non-finite anchors
        with_(5, np.full_like(args[5], np.inf)),
        with_(5, np.zeros((nc, 2, 2))),                            # p (nc, 2, 2)
        with_(6, np.zeros((nc, 3), np.int64)),                     # idx (nc, 3)
        with_(7, np.zeros((nc, 3))),                               # coef (nc, 3)
    ]
    for a in bad:
        with pytest.raises((ValueError, TypeError)):
            _core.Constraints(*a)
    with pytest.raises(TypeError):
        _core.Constraints(*with_(1, "kind"))
    with pytest.raises(TypeError):
        _core.Constraints(None, *args[1:])
    # a coupling whose coordinates are out of range
    kind, idx = np.full(1, 3, np.int64), np.array([[0, 0, model.nq, model.nv]], np.int64)
    with pytest.raises(ValueError):
        _core.Constraints(model.core, kind, np.zeros(1, np.int64), np.full((1, 2), -1, np.int64),
                          np.zeros((1, 2, 3, 3)), np.zeros((1, 2, 3)), idx, np.ones((1, 2)), 1)


def test_constraints_of_another_model_are_refused(model):
    con = core_constraints(model)
    other = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "puma560.urdf"))
    q, v = np.zeros(other.nq), np.zeros(other.nv)
    with pytest.raises(ValueError):
        _core.constrained_forward_dynamics(other.core, con, q, v, v, 0.0, 0.0)
    with pytest.raises(ValueError):
        _core.constraint_terms_batch(other.core, con, q[None], v[None], 0, np.empty((1, con.m)), 1, np.inf)


def test_single_call_answers_none_for_what_it_does_not_take(model):
    con, nq, nv = core_constraints(model), model.nq, model.nv
    rng = np.random.default_rng(0)
    q = dynamics.assemble(model, model.neutral() + 0.05 * rng.normal(size=nq))
    v, tau = rng.normal(size=nv), rng.normal(size=nv)
    a, lam = _core.constrained_forward_dynamics(model.core, con, q, v, tau, 10.0, 10.0)
    assert a.shape == (nv,) and lam.shape == (con.m,)
    nan = v.copy()
    nan[0] = np.nan
    for args in [(q[:-1], v, tau), (q, v[:-1], tau), (q, v, tau.astype(np.float32)), (q[None], v, tau),
                 (q, np.empty(2 * nv)[::2], tau), (q, nan, tau), (q, v, nan), (np.full(nq, np.inf), v, tau),
                 ("q", v, tau), (None, v, tau), (list(q), v, tau)]:
        assert _core.constrained_forward_dynamics(model.core, con, *args, 10.0, 10.0) is None
    assert _core.constrained_forward_dynamics(model.core, con, q, v, tau, np.nan, 10.0) is None
    for bad in (None, "model", q):
        with pytest.raises(TypeError):
            _core.constrained_forward_dynamics(bad, con, q, v, tau, 0.0, 0.0)
        with pytest.raises(TypeError):
            _core.constrained_forward_dynamics(model.core, bad, q, v, tau, 0.0, 0.0)


def test_batches_with_shapes_no_public_function_passes_are_refused(model):
    c, con, nq, nv, m = model.core, core_constraints(model), model.nq, model.nv, core_constraints(model).m
    Q, V, g = np.tile(model.neutral(), (4, 1)), np.zeros((4, nv)), np.zeros(3)
    out = np.empty((4, nv + m))
    assert _core.constrained_forward_dynamics_batch(c, con, Q, V, V, g, 0.0, 0.0, out, 2, np.inf) == (4, False, -1, -1)
    assert _core.constraint_terms_batch(c, con, Q, V, 1, np.empty((4, m, nv)), 2, np.inf)[0] == 4
    assert _core.project_velocity_batch(c, con, Q, V, np.empty((4, nv)), 2, np.inf)[0] == 4
    fd, terms, proj = (_core.constrained_forward_dynamics_batch, _core.constraint_terms_batch,
                       _core.project_velocity_batch)
    bad_calls = [
        lambda: fd(c, con, Q[:, :-1], V, V, g, 0.0, 0.0, out, 2, np.inf),
        lambda: fd(c, con, Q[:3], V, V, g, 0.0, 0.0, out, 2, np.inf),
        lambda: fd(c, con, Q, V[:, :-1], V, g, 0.0, 0.0, out, 2, np.inf),
        lambda: fd(c, con, Q, V, V[:2], g, 0.0, 0.0, out, 2, np.inf),
        lambda: fd(c, con, Q, V, V, np.zeros(2), 0.0, 0.0, out, 2, np.inf),
        lambda: fd(c, con, Q, V, V, g, 0.0, 0.0, np.empty((4, nv)), 2, np.inf),
        lambda: fd(c, con, Q, V, V, g, 0.0, 0.0, np.empty((4, nv + m), np.float32), 2, np.inf),
        lambda: fd(c, con, Q, V, V, g, 0.0, 0.0, np.empty((4, 2 * (nv + m)))[:, ::2], 2, np.inf),
        lambda: fd(c, con, Q, V, V, g, 0.0, 0.0, out.tolist(), 2, np.inf),
        lambda: fd(c, con, Q[None], V, V, g, 0.0, 0.0, out, 2, np.inf),
        lambda: terms(c, con, Q, V, 3, np.empty((4, m)), 2, np.inf),
        lambda: terms(c, con, Q, V, -1, np.empty((4, m)), 2, np.inf),
        lambda: terms(c, con, Q, V, 0, np.empty((4, m + 1)), 2, np.inf),
        lambda: terms(c, con, Q, V, 1, np.empty((4, m)), 2, np.inf),
        lambda: terms(c, con, Q, V, 1, np.empty((4, m, nv + 1)), 2, np.inf),
        lambda: terms(c, con, Q, V[:, :-1], 2, np.empty((4, m)), 2, np.inf),
        lambda: terms(c, con, Q[:, :-1], V, 0, np.empty((4, m)), 2, np.inf),
        lambda: proj(c, con, Q, V, np.empty((4, nv + 1)), 2, np.inf),
        lambda: proj(c, con, Q, V[:3], np.empty((4, nv)), 2, np.inf),
    ]
    for call in bad_calls:
        with pytest.raises((ValueError, TypeError)):
            call()
    # an empty batch does nothing; a non-contiguous or float32 input is converted, not read out of bounds
    assert fd(c, con, Q[:0], V[:0], V[:0], g, 0.0, 0.0, out[:0], 2, np.inf) == (0, False, -1, -1)
    ref = out.copy()
    fd(c, con, np.asfortranarray(Q), V.astype(np.float32), np.zeros((8, nv))[::2], g, 0.0, 0.0, out, 2, np.inf)
    np.testing.assert_array_equal(out, ref)


def test_projection_refuses_what_it_does_not_take(model):
    c, con, nq = model.core, core_constraints(model), model.nq
    rng = np.random.default_rng(3)
    q = dynamics.assemble(model, model.neutral() + 0.05 * rng.normal(size=nq))
    out = np.empty(nq)
    assert _core.project_position(c, con, q + 1e-6, 1e-12, 50, out) <= 1e-12
    assert np.abs(dynamics.constraint_residual(model, out)).max() <= 1e-12
    nan = q.copy()
    nan[0] = np.nan
    for args in [(q[:-1], out), (q, out[:-1]), (nan, out), (q, out.astype(np.float32)), (q, np.empty(2 * nq)[::2]),
                 (q[None], out), (q, list(out))]:
        with pytest.raises((ValueError, TypeError)):
            _core.project_position(c, con, args[0], 1e-12, 10, args[1])
    with pytest.raises(ValueError):
        _core.project_position(c, con, q, 1e-12, -1, out)


def test_public_functions_name_the_bad_argument(model):
    q, v = model.neutral(), np.zeros(model.nv)
    nan = v.copy()
    nan[0] = np.nan
    for call in [lambda: dynamics.constrained_forward_dynamics(model, q[:-1], v, v),
                 lambda: dynamics.constrained_forward_dynamics(model, q, nan, v),
                 lambda: dynamics.constrained_forward_dynamics(model, q, v, np.zeros((2, 3, 4))),
                 lambda: dynamics.constrained_forward_dynamics(model, q, v, v, baumgarte=(np.nan, 1.0)),
                 lambda: dynamics.constraint_residual(model, np.full(model.nq, np.nan)),
                 lambda: dynamics.constraint_jacobian(model, "q"),
                 lambda: dynamics.constraint_bias(model, q, v[:-1]),
                 lambda: dynamics.project_velocity(model, q, nan)]:
        with pytest.raises(dynamics.InputError):
            call()


def test_a_batch_is_the_single_calls(model):
    rng = np.random.default_rng(2)
    B = 70  # threaded
    Q = dynamics.assemble(model, np.tile(model.neutral(), (B, 1)) + 0.05 * rng.normal(size=(B, model.nq)))
    V, T = rng.normal(size=(B, model.nv)), rng.normal(size=(B, model.nv))
    a, lam = dynamics.constrained_forward_dynamics(model, Q, V, T, baumgarte=(5.0, 7.0))
    for b in (0, 33, B - 1):
        a1, lam1 = dynamics.constrained_forward_dynamics(model, Q[b], V[b], T[b], baumgarte=(5.0, 7.0))
        np.testing.assert_array_equal(a1, a[b])
        np.testing.assert_array_equal(lam1, lam[b])


def test_the_simulation_refuses_a_bad_constrained_problem(model, monkeypatch):
    """simulate's call of the core's run, repeated with what no caller passes as its constrained problem."""
    captured = {}
    real = _core.run

    def spy(*args):
        captured["args"] = args
        return real(*args)

    monkeypatch.setattr(_core, "run", spy)
    rng = np.random.default_rng(5)
    q0 = dynamics.assemble(model, model.neutral() + 0.05 * rng.normal(size=model.nq))
    dynamics.simulate(model, q0, np.zeros(model.nv), 0.01, integrator="rk4", dt=0.005, error_estimate="none",
                      progress=False)
    *args, constrained, contact = captured["args"]
    assert contact is None
    con, alpha, beta, project, lam, drift = constrained
    T, other = args[8].shape[0], core_constraints(dynamics.load_urdf(os.path.join(OUR_ROBOTS, "cassie_like_leg.urdf")))
    for bad in [(con, alpha, beta, project, lam), (con, np.nan, beta, project, lam, drift),
                (con, alpha, beta, project, np.empty((T + 1, con.m)), drift),
                (con, alpha, beta, project, np.empty((T, con.m + 1)), drift),
                (con, alpha, beta, project, lam, np.zeros(2)), (con, alpha, beta, project, lam, np.zeros(3, np.float32)),
                (con, alpha, beta, project, lam, np.zeros(6)[::2]), (other, alpha, beta, project, lam, drift),
                (None, alpha, beta, project, lam, drift), (con, "alpha", beta, project, lam, drift), "constraints"]:
        with pytest.raises((ValueError, TypeError)):
            real(*args, bad, None)


# -- constrained inverse dynamics, the constrained derivatives, the drift ---------------------------------------

def test_new_entries_refuse_constraints_of_another_model(model):
    con = core_constraints(model)
    other = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "puma560.urdf"))
    q, v, nv = np.zeros(other.nq), np.zeros(other.nv), other.nv
    Q, V, g = q[None], v[None], np.zeros(3)
    calls = [
        lambda: _core.constrained_forward_dynamics_derivatives(other.core, con, q, v, v, 0.0, 0.0),
        lambda: _core.constrained_forward_dynamics_derivatives_batch(other.core, con, Q, V, V, g, 0.0, 0.0,
                                                                     np.empty((1, 3, nv + con.m, nv)), 1, np.inf),
        lambda: _core.constrained_inverse_dynamics_batch(other.core, con, Q, V, V, g, np.ones(nv), np.empty((1, nv)),
                                                         1, np.inf),
        lambda: _core.constraint_drift(other.core, con, q, v),
    ]
    for call in calls:
        with pytest.raises(ValueError):
            call()


def test_derivatives_single_call_answers_none_for_what_it_does_not_take(model):
    con, nq, nv = core_constraints(model), model.nq, model.nv
    rng = np.random.default_rng(0)
    q = dynamics.assemble(model, model.neutral() + 0.05 * rng.normal(size=nq))
    v, tau = rng.normal(size=nv), rng.normal(size=nv)
    out = _core.constrained_forward_dynamics_derivatives(model.core, con, q, v, tau, 10.0, 10.0)
    assert out.shape == (3, nv + con.m, nv)
    nan = v.copy()
    nan[0] = np.nan
    for args in [(q[:-1], v, tau), (q, v[:-1], tau), (q, v, tau.astype(np.float32)), (q[None], v, tau),
                 (q, np.empty(2 * nv)[::2], tau), (q, nan, tau), (q, v, nan), (np.full(nq, np.inf), v, tau),
                 ("q", v, tau), (None, v, tau), (list(q), v, tau)]:
        assert _core.constrained_forward_dynamics_derivatives(model.core, con, *args, 10.0, 10.0) is None
    assert _core.constrained_forward_dynamics_derivatives(model.core, con, q, v, tau, np.inf, 1.0) is None
    for bad in (None, "model", q):
        with pytest.raises(TypeError):
            _core.constrained_forward_dynamics_derivatives(bad, con, q, v, tau, 0.0, 0.0)
        with pytest.raises(TypeError):
            _core.constrained_forward_dynamics_derivatives(model.core, bad, q, v, tau, 0.0, 0.0)


def test_derivatives_and_inverse_batches_refuse_bad_shapes(model):
    c, con, nv = model.core, core_constraints(model), model.nv
    m, B = con.m, 4
    rng = np.random.default_rng(1)
    Q = dynamics.assemble(model, np.tile(model.neutral(), (B, 1)) + 0.05 * rng.normal(size=(B, model.nq)))
    V, T, g = rng.normal(size=(B, nv)), rng.normal(size=(B, nv)), np.array(model.gravity, float)
    out = np.empty((B, 3, nv + m, nv))
    dd = _core.constrained_forward_dynamics_derivatives_batch
    assert dd(c, con, Q, V, T, g, 0.0, 0.0, out, 2, np.inf) == (B, False, -1, -1)
    A, _ = dynamics.constrained_forward_dynamics(model, Q, V, T)
    tau, mask = np.empty((B, nv)), np.ones(nv)
    cid = _core.constrained_inverse_dynamics_batch
    assert cid(c, con, Q, V, A, g, mask, tau, 2, np.inf) == (B, False, -1, -1)
    bad_calls = [
        lambda: dd(c, con, Q[:, :-1], V, T, g, 0.0, 0.0, out, 2, np.inf),
        lambda: dd(c, con, Q[:3], V, T, g, 0.0, 0.0, out, 2, np.inf),
        lambda: dd(c, con, Q, V[:, :-1], T, g, 0.0, 0.0, out, 2, np.inf),
        lambda: dd(c, con, Q, V, T[:2], g, 0.0, 0.0, out, 2, np.inf),
        lambda: dd(c, con, Q, V, T, np.zeros(2), 0.0, 0.0, out, 2, np.inf),
        lambda: dd(c, con, Q, V, T, g, np.nan, 0.0, out, 2, np.inf),
        lambda: dd(c, con, Q, V, T, g, 0.0, 0.0, np.empty((B, 3, nv, nv)), 2, np.inf),
        lambda: dd(c, con, Q, V, T, g, 0.0, 0.0, np.empty((B, 2, nv + m, nv)), 2, np.inf),
        lambda: dd(c, con, Q, V, T, g, 0.0, 0.0, out.astype(np.float32), 2, np.inf),
        lambda: dd(c, con, Q, V, T, g, 0.0, 0.0, np.empty((B, 3, nv + m, 2 * nv))[..., ::2], 2, np.inf),
        lambda: dd(c, con, Q, V, T, g, 0.0, 0.0, out.tolist(), 2, np.inf),
        lambda: dd(c, con, Q[None], V, T, g, 0.0, 0.0, out, 2, np.inf),
        lambda: cid(c, con, Q[:, :-1], V, A, g, mask, tau, 2, np.inf),
        lambda: cid(c, con, Q, V[:3], A, g, mask, tau, 2, np.inf),
        lambda: cid(c, con, Q, V, A[:, :-1], g, mask, tau, 2, np.inf),
        lambda: cid(c, con, Q, V, A, g, mask[:-1], tau, 2, np.inf),
        lambda: cid(c, con, Q, V, A, g, np.full(nv, np.nan), tau, 2, np.inf),
        lambda: cid(c, con, Q, V, A, g, np.full(nv, 0.5), tau, 2, np.inf),
        lambda: cid(c, con, Q, V, A, g, mask, np.empty((B, nv + 1)), 2, np.inf),
        lambda: cid(c, con, Q, V, A, g, mask, tau.astype(np.float32), 2, np.inf),
        lambda: cid(c, con, Q, V, A, g, mask, np.empty((B, 2 * nv))[:, ::2], 2, np.inf),
        lambda: cid(c, con, Q, V, A, np.zeros(4), mask, tau, 2, np.inf),
    ]
    for call in bad_calls:
        with pytest.raises((ValueError, TypeError)):
            call()
    # an empty batch does nothing; non-contiguous and float32 inputs are converted, not read out of bounds
    assert dd(c, con, Q[:0], V[:0], T[:0], g, 0.0, 0.0, out[:0], 2, np.inf) == (0, False, -1, -1)
    assert cid(c, con, Q[:0], V[:0], A[:0], g, mask, tau[:0], 2, np.inf) == (0, False, -1, -1)
    ref = out.copy()
    dd(c, con, np.asfortranarray(Q), np.asfortranarray(V), np.repeat(T, 2, axis=0)[::2], g, 0.0, 0.0,
       out, 2, np.inf)
    np.testing.assert_array_equal(out, ref)
    # NaN states: no crash, a finite-or-not answer but never a read out of bounds
    Qn = Q.copy()
    Qn[1, 0] = np.nan
    dd(c, con, Qn, V, T, g, 0.0, 0.0, out, 2, np.inf)
    cid(c, con, Qn, V, A, g, mask, tau, 2, np.inf)


def test_drift_refuses_what_it_does_not_take(model):
    c, con, nq, nv = model.core, core_constraints(model), model.nq, model.nv
    q, v = model.neutral(), np.zeros(nv)
    assert len(_core.constraint_drift(c, con, q, v)) == 2
    nan = v.copy()
    nan[0] = np.nan
    for args in [(q[:-1], v), (q, v[:-1]), (q, nan), (np.full(nq, np.inf), v), (q[None], v), ("q", v)]:
        with pytest.raises((ValueError, TypeError)):
            _core.constraint_drift(c, con, *args)
    # float32 and non-contiguous inputs are converted, not read out of bounds
    ref = _core.constraint_drift(c, con, q, v)
    assert _core.constraint_drift(c, con, np.repeat(q, 2)[::2], v.astype(np.float32)) == ref


def test_new_public_functions_name_the_bad_argument(model):
    q, v = model.neutral(), np.zeros(model.nv)
    nan = v.copy()
    nan[0] = np.nan
    for call in [lambda: dynamics.constrained_forward_dynamics_derivatives(model, q[:-1], v, v),
                 lambda: dynamics.constrained_forward_dynamics_derivatives(model, q, nan, v),
                 lambda: dynamics.constrained_forward_dynamics_derivatives(model, q, v, v, baumgarte=(1.0, np.inf)),
                 lambda: dynamics.constrained_forward_dynamics_derivatives(model, q, v, "tau"),
                 lambda: dynamics.constrained_inverse_dynamics(model, q, nan, v, actuated=list(model.joint_names)),
                 lambda: dynamics.constrained_inverse_dynamics(model, q[:-1], v, v, actuated=list(model.joint_names)),
                 lambda: dynamics.constrained_inverse_dynamics(model, q, v, v, actuated="theta1"),
                 lambda: dynamics.constrained_inverse_dynamics(model, q, v, v, actuated=[3])]:
        with pytest.raises(dynamics.InputError):
            call()


def test_derivatives_and_inverse_batches_are_the_single_calls(model):
    rng = np.random.default_rng(6)
    B = 70  # threaded
    Q = dynamics.assemble(model, np.tile(model.neutral(), (B, 1)) + 0.05 * rng.normal(size=(B, model.nq)))
    V, T = rng.normal(size=(B, model.nv)), rng.normal(size=(B, model.nv))
    batch = dynamics.constrained_forward_dynamics_derivatives(model, Q, V, T, baumgarte=(5.0, 7.0))
    A, _ = dynamics.constrained_forward_dynamics(model, Q, V, T)
    tau = dynamics.constrained_inverse_dynamics(model, Q, V, A, actuated=list(model.joint_names))
    for b in (0, 33, B - 1):
        one = dynamics.constrained_forward_dynamics_derivatives(model, Q[b], V[b], T[b], baumgarte=(5.0, 7.0))
        for x, y in zip(one, batch):
            np.testing.assert_array_equal(x, y[b])
        np.testing.assert_array_equal(
            dynamics.constrained_inverse_dynamics(model, Q[b], V[b], A[b], actuated=list(model.joint_names)), tau[b])
