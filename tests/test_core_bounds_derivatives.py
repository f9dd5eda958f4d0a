"""The C++ core's analytical derivatives (core/rnea_derivatives.cpp, core/aba_derivatives.cpp), run as they are and
under AddressSanitizer and UndefinedBehaviorSanitizer (.ci/run's sanitizer stage), as test_core_bounds.py does for
the tree algorithms: the identities that prove them (central differences of inverse_dynamics and forward_dynamics
on the manifold, M and M^-1, a threaded batch equal to its single states) on random trees of every joint type, the
numba kernels the simulation still links giving the same numbers, and every entry of the extension called directly
with what no public function passes (wrong shapes, dtypes, layouts, NaN, a zero quaternion, empty batches): None
or a clear error, never a crash or a read out of bounds."""

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.aba_derivatives import _aba_derivatives_into, _work_size
from dynamics._numba import address
from dynamics.rnea_derivatives import rnea_derivatives_at
from robots import ALL_TYPES, chain_urdf, random_state, random_urdf

TREES = [(random_urdf(np.random.default_rng(s), 8, types=ALL_TYPES), False) for s in range(3)] + \
        [(random_urdf(np.random.default_rng(20 + s), 6), True) for s in range(2)]
STEP = 1e-7
FD_RTOL = 1e-6


@pytest.fixture(scope="module", params=range(len(TREES)))
def model(request):
    text, floating = TREES[request.param]
    return dynamics.load_urdf(text, floating_base=floating)


def rel(x, ref):
    return np.linalg.norm(np.asarray(x) - ref) / max(np.linalg.norm(ref), 1.0)


def tangent_fd(f, model, q):
    """Central differences of f along q (+) (h e_k) for each tangent direction k: (len f, nv)."""
    cols = []
    for k in range(model.nv):
        e = np.zeros(model.nv)
        e[k] = STEP
        cols.append((f(dynamics.integrate(model, q, e)) - f(dynamics.integrate(model, q, -e))) / (2 * STEP))
    return np.array(cols).T


def vector_fd(f, x):
    cols = []
    for k in range(x.shape[0]):
        e = np.zeros_like(x)
        e[k] = STEP
        cols.append((f(x + e) - f(x - e)) / (2 * STEP))
    return np.array(cols).T


def test_derivatives_are_those_of_inverse_and_forward_dynamics(model):
    rng = np.random.default_rng(2)
    q, v, a = random_state(model, rng)
    tau = rng.normal(size=model.nv)
    dq, dv, M = dynamics.inverse_dynamics_derivatives(model, q, v, a)
    assert rel(dq, tangent_fd(lambda x: dynamics.inverse_dynamics(model, x, v, a), model, q)) < FD_RTOL
    assert rel(dv, vector_fd(lambda x: dynamics.inverse_dynamics(model, q, x, a), v)) < FD_RTOL
    np.testing.assert_allclose(M, dynamics.mass_matrix(model, q), rtol=1e-12, atol=1e-12)
    fq, fv, Minv = dynamics.forward_dynamics_derivatives(model, q, v, tau)
    assert rel(fq, tangent_fd(lambda x: dynamics.forward_dynamics(model, x, v, tau), model, q)) < FD_RTOL
    assert rel(fv, vector_fd(lambda x: dynamics.forward_dynamics(model, q, x, tau), v)) < FD_RTOL
    np.testing.assert_allclose(Minv, dynamics.inverse_mass_matrix(model, q), rtol=1e-10, atol=1e-10)
    # with gravity and external forces (the general path)
    F = rng.normal(size=(model.nbodies, 6))
    g = np.array([0.3, -1.0, -9.0])
    dq, dv, _ = dynamics.inverse_dynamics_derivatives(model, q, v, a, gravity=g, f_ext=F)
    assert rel(dq, tangent_fd(lambda x: dynamics.inverse_dynamics(model, x, v, a, gravity=g, f_ext=F), model,
                              q)) < FD_RTOL
    fq, fv, _ = dynamics.forward_dynamics_derivatives(model, q, v, tau, gravity=g, f_ext=F)
    assert rel(fq, tangent_fd(lambda x: dynamics.forward_dynamics(model, x, v, tau, gravity=g, f_ext=F), model,
                              q)) < FD_RTOL
    assert rel(fv, vector_fd(lambda x: dynamics.forward_dynamics(model, q, x, tau, gravity=g, f_ext=F), v)) < FD_RTOL


def test_a_threaded_batch_equals_its_single_states(model):
    rng = np.random.default_rng(3)
    Q, V, A = (np.array(x) for x in zip(*(random_state(model, rng) for _ in range(70))))  # over the threads
    for f in (dynamics.inverse_dynamics_derivatives, dynamics.forward_dynamics_derivatives):
        batch = f(model, Q, V, A)
        assert all(x.shape == (70, model.nv, model.nv) for x in batch)
        for k in (0, 35, 69):
            for got, ref in zip(batch, f(model, Q[k], V[k], A[k])):
                np.testing.assert_array_equal(got[k], ref)


def test_the_core_gives_the_numba_kernels_numbers(model):
    """The simulation still links the numba kernels: both give the same numbers."""
    rng = np.random.default_rng(4)
    nv, nb = model.nv, model.nbodies
    buf = np.empty(_work_size(nb, nv))
    for _ in range(3):
        q, v, a = random_state(model, rng)
        F = rng.normal(size=(nb, 6))
        ref = [np.empty((nv, nv)) for _ in range(3)]
        rnea_derivatives_at(model.tree, q, v, a, model.gravity, F, *ref)
        got = dynamics.inverse_dynamics_derivatives(model, q, v, a, f_ext=F)
        for x, y in zip(got, ref):
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()))
        ref = [np.empty((nv, nv)) for _ in range(3)]
        assert _aba_derivatives_into(model.tree, q, v, a, model.gravity, F, address(buf), *ref) == -1
        got = dynamics.forward_dynamics_derivatives(model, q, v, a, f_ext=F)
        for x, y in zip(got, ref):
            np.testing.assert_allclose(x, y, rtol=1e-10, atol=1e-11 * max(1.0, np.abs(y).max()))


def test_single_calls_refuse_what_is_not_an_exact_state(model):
    """None sends the public function to its general path, which converts or names the argument."""
    c, nq, nv = model.core, model.nq, model.nv
    q, v, a = random_state(model, np.random.default_rng(5))
    for call in (_core.rnea_derivatives, _core.aba_derivatives):
        out = call(c, q, v, a)
        assert len(out) == 3 and all(x.shape == (nv, nv) and x.dtype == np.float64 for x in out)
        nan = v.copy()
        nan[-1] = np.nan
        zero_quaternion = q.copy()  # a free, spherical or planar joint's quaternion or (cos, sin) all zero
        units = {"floating": (3, 7), "spherical": (0, 4), "planar": (2, 4)}
        for t, k in zip(model.joint_types, model.q_index):
            if t in units:
                zero_quaternion[k + units[t][0]:k + units[t][1]] = 0.0
        refused = [(q[:-1], v, a), (q, v[:-1], a), (q, v, np.append(a, 0.0)), (q.astype(np.float32), v, a),
                   (q, v.astype(np.int64), a), (np.repeat(q, 2)[::2], v, a), (q, np.array([v]), a),
                   (q, nan, a), (q, v, nan), (np.full(nq, np.inf), v, a), (list(q), v, a), (None, v, a),
                   (q.astype(">f8"), v, a), (q, v, a.view(np.matrix))]
        if any(t in units for t in model.joint_types):
            refused.append((zero_quaternion, v, a))
        for args in refused:
            assert call(c, *args) is None
        with pytest.raises(TypeError):
            call("not a model", q, v, a)


def test_batches_with_shapes_no_public_function_passes_are_refused(model):
    c, nq, nv, nb = model.core, model.nq, model.nv, model.nbodies
    Q, V = np.zeros((4, nq)), np.zeros((4, nv))
    Q[:] = model.neutral()
    g, F = np.zeros(3), np.zeros((1, 0, 6))
    out = np.empty((4, 3, nv, nv))
    for batch in (_core.rnea_derivatives_batch, _core.aba_derivatives_batch):
        assert batch(c, Q, V, V, F, g, out, 2, np.inf) == (4, False, -1, -1)
        bad_calls = [
            lambda: batch(c, Q[:, :-1], V, V, F, g, out, 2, np.inf),
            lambda: batch(c, Q[:3], V, V, F, g, out, 2, np.inf),
            lambda: batch(c, Q, V[:, :-1], V, F, g, out, 2, np.inf),
            lambda: batch(c, Q, V, V[:2], F, g, out, 2, np.inf),
            lambda: batch(c, Q, V, V[:, :-1], F, g, out, 2, np.inf),
            lambda: batch(c, Q[0], V, V, F, g, out, 2, np.inf),
            lambda: batch(c, Q, V, V, np.zeros((1, nb + 1, 6)), g, out, 2, np.inf),
            lambda: batch(c, Q, V, V, np.zeros((2, nb, 6)), g, out, 2, np.inf),
            lambda: batch(c, Q, V, V, np.zeros((1, nb, 5)), g, out, 2, np.inf),
            lambda: batch(c, Q, V, V, F, np.zeros(2), out, 2, np.inf),
            lambda: batch(c, Q, V, V, F, g, np.empty((4, 2, nv, nv)), 2, np.inf),
            lambda: batch(c, Q, V, V, F, g, np.empty((4, 3, nv, nv + 1)), 2, np.inf),
            lambda: batch(c, Q, V, V, F, g, np.empty((4, 3, nv + 1, nv)), 2, np.inf),
            lambda: batch(c, Q, V, V, F, g, np.empty((5, 3, nv, nv)), 2, np.inf),
            lambda: batch(c, Q, V, V, F, g, np.empty((4, 3 * nv, nv)), 2, np.inf),  # wrong rank
            lambda: batch(c, Q, V, V, F, g, np.empty((4, 3, nv, nv), np.float32), 2, np.inf),
            lambda: batch(c, Q, V, V, F, g, np.empty((4, 3, nv, nv)).transpose(0, 1, 3, 2), 2, np.inf),
            lambda: batch(c, Q, V, V, F, g, np.empty((4, 3, nv, 2 * nv))[..., ::2], 2, np.inf),
            lambda: batch(c, Q, V, V, F, g, out.tolist(), 2, np.inf),
            lambda: batch(c, Q.astype(np.complex128), V, V, F, g, out, 2, np.inf),
            lambda: batch("not a model", Q, V, V, F, g, out, 2, np.inf),
        ]
        for call in bad_calls:  # a wrong size is a ValueError naming it, a wrong rank or layout a TypeError
            with pytest.raises((ValueError, TypeError)):
                call()
        strided = np.zeros((4, 2 * nq))[:, ::2]  # an input of the right shape in another layout is copied, not read
        strided[:] = Q
        assert batch(c, strided, V, V, F, g, out, 2, np.inf) == (4, False, -1, -1)
        assert batch(c, Q.astype(np.float32), V, V, F, g, out, 2, np.inf) == (4, False, -1, -1)
        # empty batches compute nothing; one shared row serves every state
        assert batch(c, np.zeros((0, nq)), V[:0], V[:0], F, g, np.empty((0, 3, nv, nv)), 2, np.inf) == \
            (0, False, -1, -1)
        assert batch(c, Q[:1], V[:1], V[:1], F, g, out, 2, np.inf) == (4, False, -1, -1)


def test_public_functions_name_what_is_wrong(model):
    q, v, a = random_state(model, np.random.default_rng(6))
    for f in (dynamics.inverse_dynamics_derivatives, dynamics.forward_dynamics_derivatives):
        with pytest.raises(dynamics.InputError, match="q"):
            f(model, q[:-1], v, a)
        with pytest.raises(dynamics.InputError, match="v"):
            f(model, q, np.full(model.nv, np.nan), a)
        with pytest.raises(dynamics.InputError, match="f_ext"):
            f(model, q, v, a, f_ext=np.zeros((model.nbodies + 1, 6)))
        with pytest.raises(dynamics.InputError, match="gravity"):
            f(model, q, v, a, gravity=np.zeros(2))
        with pytest.raises(dynamics.InputError, match="model"):
            f("not a model", q, v, a)
        # another dtype or layout is converted by the general path, with the same numbers
        for got, ref in zip(f(model, list(q), v.astype(np.float32).astype(np.float64)[::1], np.repeat(a, 2)[::2]),
                            f(model, q, v.astype(np.float32).astype(np.float64), a)):
            np.testing.assert_array_equal(got, ref)


def test_a_singular_joint_is_named():
    text = chain_urdf(2)  # the last link carries nothing: M is singular at joint1
    head, tail = text.rsplit('<link name="link1">', 1)
    model = dynamics.load_urdf(head + '<link name="link1"/>' + tail.split("</link>", 1)[1])
    q, zero = np.array([0.1, 0.2]), np.zeros(2)
    assert _core.aba_derivatives(model.core, q, zero, zero) is None
    with pytest.raises(dynamics.InputError, match="singular at joint 'joint1'"):
        dynamics.forward_dynamics_derivatives(model, q, zero, zero)
    with pytest.raises(dynamics.InputError, match="singular at joint 'joint1'"):
        dynamics.forward_dynamics_derivatives(model, np.tile(q, (70, 1)), zero, zero)
    out = np.empty((70, 3, 2, 2))
    done, expired, failed, body = _core.aba_derivatives_batch(model.core, np.tile(q, (70, 1)), zero[None],
                                                              zero[None], np.zeros((1, 0, 6)), np.zeros(3), out,
                                                              2, np.inf)
    assert not expired and failed == 0 and body == 1
    dq, dv, M = dynamics.inverse_dynamics_derivatives(model, q, zero, zero)  # RNEA's derivatives are defined
    assert M[1, 1] == 0.0


def test_configuration_jacobians_are_those_of_integrate_and_difference(model):
    rng = np.random.default_rng(7)
    q0, v, _ = random_state(model, rng)
    q1, _, _ = random_state(model, rng)
    Jq, Jv = dynamics.integrate_jacobians(model, q0, v)
    base = dynamics.integrate(model, q0, v)
    assert rel(Jq, tangent_fd(lambda x: dynamics.difference(model, base, dynamics.integrate(model, x, v)), model,
                              q0)) < FD_RTOL
    assert rel(Jv, vector_fd(lambda x: dynamics.difference(model, base, dynamics.integrate(model, q0, x)), v)) < FD_RTOL
    J0, J1 = dynamics.difference_jacobians(model, q0, q1)
    assert rel(J1, tangent_fd(lambda x: dynamics.difference(model, q0, x), model, q1)) < FD_RTOL
    assert rel(J0, tangent_fd(lambda x: dynamics.difference(model, x, q1), model, q0)) < FD_RTOL
    J0, J1 = dynamics.difference_jacobians(model, q0, q0)  # at d = 0: -1 and 1
    np.testing.assert_allclose(J1, np.eye(model.nv), atol=1e-15)
    np.testing.assert_allclose(J0, -np.eye(model.nv), atol=1e-15)


def test_configuration_jacobians_refuse_wrong_shapes(model):
    c, nv = model.core, model.nv
    d, A, B = np.zeros(nv), np.empty((nv, nv)), np.empty((nv, nv))
    _core.integrate_jacobians(c, d, A, B)
    np.testing.assert_array_equal(A, np.eye(nv))
    assert _core.difference_jacobians(c, d, A, B)
    np.testing.assert_array_equal(A, -np.eye(nv))
    for entry in (_core.integrate_jacobians, _core.difference_jacobians):
        bad_calls = [
            lambda: entry(c, d[:-1], A, B),
            lambda: entry(c, np.zeros(nv + 1), A, B),
            lambda: entry(c, d[None], A, B),
            lambda: entry(c, d, A[:-1], B),
            lambda: entry(c, d, A, np.empty((nv, nv + 1))),
            lambda: entry(c, d, np.empty(nv * nv), B),
            lambda: entry(c, d, A, np.empty((nv, nv), np.float32)),
            lambda: entry(c, d, np.empty((nv, 2 * nv))[:, ::2], B),
            lambda: entry(c, d, A, B.tolist()),
            lambda: entry("not a model", d, A, B),
        ]
        for call in bad_calls:
            with pytest.raises((ValueError, TypeError)):
                call()
    q, v, _ = random_state(model, np.random.default_rng(8))
    with pytest.raises(dynamics.InputError, match="v"):
        dynamics.integrate_jacobians(model, q, np.full(nv, np.nan))
    with pytest.raises(dynamics.InputError, match="q1"):
        dynamics.difference_jacobians(model, q, q[:-1])


def test_kinematics_derivatives_are_those_of_the_frame_motions(model):
    rng = np.random.default_rng(9)
    q, v, a = random_state(model, rng)
    frame = model.frame_names[-1]
    for ref in ("world", "local", "local_world_aligned"):
        dv_dq, da_dq, da_dv, da_da = dynamics.frame_acceleration_derivatives(model, q, v, a, frame, reference=ref)

        def acc(q_, v_=v, a_=a):
            return dynamics.frame_acceleration(model, q_, v_, a_, frame, reference=ref, classical=False)

        assert rel(dv_dq, tangent_fd(lambda x: dynamics.frame_velocity(model, x, v, frame, reference=ref), model,
                                     q)) < FD_RTOL
        assert rel(da_dq, tangent_fd(acc, model, q)) < FD_RTOL
        assert rel(da_dv, vector_fd(lambda x: acc(q, x), v)) < FD_RTOL
        assert rel(da_da, vector_fd(lambda x: acc(q, v, x), a)) < FD_RTOL
        for x, y in zip(dynamics.frame_velocity_derivatives(model, q, v, frame, reference=ref), (dv_dq, da_da)):
            np.testing.assert_array_equal(x, y)
    dcom, dvcom = dynamics.center_of_mass_derivatives(model, q, v)
    np.testing.assert_allclose(dcom, dynamics.com_jacobian(model, q), atol=1e-12)
    assert rel(dvcom, tangent_fd(lambda x: dynamics.center_of_mass_velocity(model, x, v), model, q)) < FD_RTOL


def test_kinematics_derivatives_refuse_wrong_shapes(model):
    c, nq, nv, nf = model.core, model.nq, model.nv, model.core.nf
    q, v = model.neutral(), np.zeros(nv)
    six, three = [np.empty((6, nv)) for _ in range(4)], [np.empty((3, nv)) for _ in range(2)]
    _core.frame_velocity_derivatives(c, q, v, nf - 1, 0, *six[:2])
    _core.frame_acceleration_derivatives(c, q, v, v, nf - 1, 2, *six)
    _core.center_of_mass_derivatives(c, q, v, *three)
    bad_calls = [
        lambda: _core.frame_velocity_derivatives(c, q[:-1], v, 0, 0, *six[:2]),
        lambda: _core.frame_velocity_derivatives(c, q, np.zeros(nv + 1), 0, 0, *six[:2]),
        lambda: _core.frame_velocity_derivatives(c, q, v, nf, 0, *six[:2]),
        lambda: _core.frame_velocity_derivatives(c, q, v, -1, 0, *six[:2]),
        lambda: _core.frame_velocity_derivatives(c, q, v, 0, 3, *six[:2]),
        lambda: _core.frame_velocity_derivatives(c, q, v, 0, -1, *six[:2]),
        lambda: _core.frame_velocity_derivatives(c, q, v, 0, 0, six[0], np.empty((6, nv + 1))),
        lambda: _core.frame_velocity_derivatives(c, q, v, 0, 0, six[0], np.empty((5, nv))),
        lambda: _core.frame_velocity_derivatives(c, q, v, 0, 0, six[0], np.empty((6, 2 * nv))[:, ::2]),
        lambda: _core.frame_acceleration_derivatives(c, q, v, v[:-1], 0, 0, *six),
        lambda: _core.frame_acceleration_derivatives(c, q, v, v, 0, 0, *six[:3], np.empty((6, nv), np.float32)),
        lambda: _core.frame_acceleration_derivatives(c, q, v, v, 0, 0, *six[:3], np.empty(6 * nv)),
        lambda: _core.center_of_mass_derivatives(c, q, v, three[0], np.empty((6, nv))),
        lambda: _core.center_of_mass_derivatives(c, q[None], v, *three),
        lambda: _core.center_of_mass_derivatives("not a model", q, v, *three),
    ]
    for call in bad_calls:
        with pytest.raises((ValueError, TypeError)):
            call()
    with pytest.raises(dynamics.InputError, match="reference"):
        dynamics.frame_velocity_derivatives(model, q, v, model.frame_names[0], reference="body")
    with pytest.raises(dynamics.InputError, match="a"):
        dynamics.frame_acceleration_derivatives(model, q, v, np.full(nv, np.nan), model.frame_names[0])
    with pytest.raises(dynamics.InputError):
        dynamics.frame_velocity_derivatives(model, q, v, "no such frame")
