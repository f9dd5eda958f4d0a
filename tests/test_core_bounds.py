"""The C++ core's memory safety, run as it is and under AddressSanitizer and UndefinedBehaviorSanitizer (.ci/run's
sanitizer stage): the identities that prove the algorithms (ABA(RNEA(a)) = a, M from RNEA's columns, M^-1 M = 1,
J v = the frame's velocity, integrate(difference) = q) on random trees of every joint type, through the public
functions, and every entry of the extension called directly with what no public function passes (wrong shapes,
lengths, indices, empty batches, an inconsistent model): a clear error or None, never a crash or a read out of
bounds."""

import numpy as np
import pytest

import dynamics
from dynamics import _core
from robots import ALL_TYPES, random_state, random_urdf

TREES = [(random_urdf(np.random.default_rng(s), 9, types=ALL_TYPES), False) for s in range(3)] + \
        [(random_urdf(np.random.default_rng(10 + s), 7, floating_joint=True), False) for s in range(2)]


@pytest.fixture(scope="module", params=range(len(TREES)))
def model(request):
    text, floating = TREES[request.param]
    return dynamics.load_urdf(text, floating_base=floating)


def test_identities_of_the_tree_algorithms(model):
    rng = np.random.default_rng(1)
    Q, V, A = (np.array(x) for x in zip(*(random_state(model, rng) for _ in range(70))))  # a threaded batch
    tau = dynamics.inverse_dynamics(model, Q, V, A)
    np.testing.assert_allclose(dynamics.forward_dynamics(model, Q, V, tau), A, rtol=1e-8, atol=1e-8)
    M = dynamics.mass_matrix(model, Q)
    bias = dynamics.bias_forces(model, Q, V)
    np.testing.assert_allclose(np.einsum("bij,bj->bi", M, A) + bias, tau, rtol=1e-9, atol=1e-9)
    Minv = dynamics.inverse_mass_matrix(model, Q)
    np.testing.assert_allclose(Minv @ M, np.broadcast_to(np.eye(model.nv), M.shape), atol=1e-8)
    g = dynamics.gravity_torques(model, Q)
    np.testing.assert_allclose(dynamics.inverse_dynamics(model, Q, 0 * V, 0 * A), g, rtol=1e-10, atol=1e-10)
    C = dynamics.coriolis_matrix(model, Q[:5], V[:5])
    np.testing.assert_allclose(np.einsum("bij,bj->bi", C, V[:5]) + g[:5], bias[:5], rtol=1e-9, atol=1e-9)
    T = dynamics.kinetic_energy(model, Q, V)
    np.testing.assert_allclose(T, 0.5 * np.einsum("bi,bij,bj->b", V, M, V), rtol=1e-10)
    frame = model.frame_names[-1]
    J = dynamics.frame_jacobian(model, Q, frame, reference="local")
    np.testing.assert_allclose(np.einsum("bij,bj->bi", J, V),
                               dynamics.frame_velocity(model, Q, V, frame, reference="local"), atol=1e-10)
    Jc = dynamics.com_jacobian(model, Q)
    np.testing.assert_allclose(np.einsum("bij,bj->bi", Jc, V), dynamics.center_of_mass_velocity(model, Q, V),
                               atol=1e-10)
    q1 = dynamics.integrate(model, Q[0], V[0], 0.1)
    np.testing.assert_allclose(dynamics.difference(model, Q[0], q1), 0.1 * V[0], atol=1e-10)


def test_batches_with_shapes_no_public_function_passes_are_refused(model):
    c, nq, nv, nb = model.core, model.nq, model.nv, model.nbodies
    Q, V = np.zeros((4, nq)), np.zeros((4, nv))
    g, F = np.zeros(3), np.zeros((1, 0, 6))
    out = np.empty((4, nv))
    ok = _core.rnea_batch(c, Q, V, V, F, g, True, True, out, 2, np.inf)
    assert ok == (4, False, -1, -1)
    bad_calls = [
        lambda: _core.rnea_batch(c, Q[:, :-1], V, V, F, g, True, True, out, 2, np.inf),
        lambda: _core.rnea_batch(c, Q[:3], V, V, F, g, True, True, out, 2, np.inf),
        lambda: _core.rnea_batch(c, Q, V[:, :-1], V, F, g, True, True, out, 2, np.inf),
        lambda: _core.rnea_batch(c, Q, V, V, np.zeros((1, nb + 1, 6)), g, True, True, out, 2, np.inf),
        lambda: _core.rnea_batch(c, Q, V, V, np.zeros((2, nb, 6)), g, True, True, out, 2, np.inf),
        lambda: _core.rnea_batch(c, Q, V, V, F, np.zeros(2), True, True, out, 2, np.inf),
        lambda: _core.rnea_batch(c, Q, V, V, F, g, True, True, np.empty((4, nv + 1)), 2, np.inf),
        lambda: _core.crba_batch(c, Q, np.empty((4, nv, nv - 1 if nv > 1 else 2)), 2, np.inf),
        lambda: _core.aba_batch(c, Q, V, V[:2], F, g, True, out, 2, np.inf),
        lambda: _core.minverse_batch(c, Q, np.empty((5, nv, nv)), 2, np.inf),
        lambda: _core.energy_batch(c, Q, V[:, :0], g, True, False, np.empty((4, 2)), 2, np.inf),
        lambda: _core.coriolis_batch(c, Q, V, np.empty((4, nv)), 2, np.inf),
        lambda: _core.placements_batch(c, Q, np.empty((4, model.core.nf + 1, 4, 4)), 2, np.inf),
        lambda: _core.frame_placement_batch(c, Q, model.core.nf, np.empty((4, 4, 4)), 2, np.inf),
        lambda: _core.frame_placement_batch(c, Q, -2, np.empty((4, 4, 4)), 2, np.inf),
        lambda: _core.frame_motion_batch(c, Q, V, V, 0, 3, 0, False, np.empty((4, 6)), 2, np.inf),
        lambda: _core.frame_motion_batch(c, Q, V, V, 0, 0, 7, False, np.empty((4, 6)), 2, np.inf),
        lambda: _core.frame_jacobian_batch(c, Q, 0, 0, np.zeros(4), np.empty((4, 6, nv)), 2, np.inf),
        lambda: _core.frame_jacobian_batch(c, Q, 0, 0, g, np.empty((4, 5, nv)), 2, np.inf),
        lambda: _core.center_of_mass_batch(c, Q, V, 2, np.empty((4, 3, 1)), 2, np.inf),
        lambda: _core.center_of_mass_batch(c, Q, V, 9, np.empty((4, 3, 1)), 2, np.inf),
        lambda: _core.jminvjt_batch(c, Q, 0, 0, np.array([0, 6]), np.empty((4, 2, 2)), 2, np.inf),
        lambda: _core.jminvjt_batch(c, Q, 0, 0, np.zeros(0, np.int64), np.empty((4, 0, 0)), 2, np.inf),
        lambda: _core.inverse_kinematics_batch(c, Q, np.zeros((4, 3, 4)), 0, 6, 1e-9, 5, 0.0, False,
                                               np.empty((4, nq + 5)), 2, np.inf),
        lambda: _core.inverse_kinematics_batch(c, Q, np.zeros((1, 4, 4)), 0, 5, 1e-9, 5, 0.0, False,
                                               np.empty((4, nq + 5)), 2, np.inf),
        lambda: _core.inverse_kinematics_batch(c, Q, np.zeros((1, 4, 4)), 0, 6, 1e-9, -1, 0.0, False,
                                               np.empty((4, nq + 5)), 2, np.inf),
        lambda: _core.frame_jacobian_time_variation(c, Q[0], V[0, :-1], 0, 0, np.empty((6, nv))),
        lambda: _core.integrate(c, Q[0], V[0], 0.1, np.empty(nq + 1)),
        lambda: _core.difference(c, Q[0], Q[0, :-1], np.empty(nv)),
    ]
    for k, call in enumerate(bad_calls):  # a wrong size is a ValueError naming it, a wrong rank nanobind's TypeError
        with pytest.raises((ValueError, TypeError)):
            call()
    strided = np.zeros((4, 2 * nq))[:, ::2]  # an input of the right shape in another layout is copied, not read
    assert _core.rnea_batch(c, strided, V, V, F, g, True, True, out, 2, np.inf) == (4, False, -1, -1)
    for call in (lambda: _core.rnea_batch(c, Q, V, V, F, g, True, True, out[:, ::-1], 2, np.inf),  # outputs: never
                 lambda: _core.crba_batch(c, Q, np.empty((4, nv, nv)).transpose(0, 2, 1), 2, np.inf)):
        with pytest.raises(TypeError):
            call()


def test_empty_batches_compute_nothing(model):
    c, nq, nv = model.core, model.nq, model.nv
    out = np.empty((0, nv))
    assert _core.rnea_batch(c, np.zeros((0, nq)), np.zeros((0, nv)), np.zeros((0, nv)), np.zeros((1, 0, 6)),
                            np.zeros(3), True, True, out, 2, np.inf) == (0, False, -1, -1)
    assert dynamics.mass_matrix(model, np.zeros((0, nq))).shape == (0, nv, nv)


def test_an_inconsistent_model_is_refused_before_any_algorithm_runs(model):
    t, fr = model.tree, model.frame_arrays
    good = dict(parents=t.parents, jtype=t.jtype, q_idx=t.q_idx, v_idx=t.v_idx, nv_j=t.nv_j, Xrot=t.Xrot,
                Xpos=t.Xpos, axis=t.axis, S=t.S, mass=t.mass, h=t.h, Io=t.Io, XK=t.XK, XKK=t.XKK,
                gravity=model.gravity, lower=model.lower, upper=model.upper, frame_body=fr.body, frame_kind=fr.kind,
                frame_R=fr.R, frame_p=fr.p)
    _core.Model(**good)
    nb = model.nbodies
    bad = {"parents": np.arange(nb), "jtype": np.full(nb, 9), "q_idx": t.q_idx + 1, "nv_j": t.nv_j + 1,
           "S": t.S[:-1], "mass": t.mass[:-1], "Xrot": t.Xrot[:-1], "frame_body": np.full(len(fr.body), nb),
           "frame_kind": np.full(len(fr.kind), 3), "lower": model.lower[:-1], "gravity": np.zeros(2)}
    for key, value in bad.items():
        with pytest.raises(ValueError):
            _core.Model(**{**good, key: value})


def test_first_nonfinite_finds_the_first_bad_row():
    """The batch checks' scan (core/checks.hpp: 64 rows at a time by the exponent bits, then row by row) against
    numpy: every kind of non-finite number in every position of a block, none among the extreme finite ones."""
    rng = np.random.default_rng(0)
    X = rng.normal(size=(300, 7))
    assert _core.first_nonfinite(X) == -1
    extremes = np.array([[5e-324, -5e-324, 1.7976931348623157e308, -1.7976931348623157e308, -0.0, 0.0, 2.2e-308]])
    assert _core.first_nonfinite(extremes) == -1
    for row, col, bad in [(0, 0, np.nan), (63, 6, np.inf), (64, 0, -np.inf), (299, 6, -np.nan), (150, 3, np.inf)]:
        Y = X.copy()
        Y[row, col] = bad
        Y[-1, -1] = np.nan  # a later one too: the first is reported
        assert _core.first_nonfinite(Y) == min(row, 299) == int(np.flatnonzero(~np.isfinite(Y).all(1))[0])
    assert _core.first_nonfinite(np.empty((0, 3))) == -1
