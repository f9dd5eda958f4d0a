"""Analytical derivatives of inverse and forward dynamics against Pinocchio (computeRNEADerivatives,
computeABADerivatives, to 1e-9 relative) and against central finite differences on the manifold (q moved by
dynamics.integrate along each tangent direction; relative error 1e-6 at step 1e-7).

A few robots and random trees (fixed and floating, with external forces) in the suite; the sweep over every
example-robot-data URDF is marked slow.
"""

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from robots import ALL_TYPES, erd, erd_urdfs, random_state, random_urdf
from robots import vector_fd as _vector_fd
from test_pinocchio import PinMap, _pin_loads, pin_force, pin_model

PIN_RTOL = 1e-9
FD_RTOL = 1e-6
STEP = 1e-7


def rel(x, ref):
    return np.linalg.norm(np.asarray(x) - ref) / max(np.linalg.norm(ref), 1.0)


def tangent_fd(f, model, q, step=STEP):
    """Central differences of f along q (+) (h e_k) for each tangent direction k: (len f, nv)."""
    cols = []
    for k in range(model.nv):
        e = np.zeros(model.nv)
        e[k] = step
        cols.append((f(dynamics.integrate(model, q, e)) - f(dynamics.integrate(model, q, -e))) / (2 * step))
    return np.array(cols).T


def vector_fd(f, x, step=STEP):
    return _vector_fd(f, x, step)


def pin_forces(model, pm, F):
    out = [pin.Force.Zero() for _ in range(pm.njoints)]
    for i, name in enumerate(model.joint_names):
        jid = pm.getJointId(name)
        out[jid] = pin_force(pm, jid, F[i])
    return out


def compare_with_pinocchio(model, pm, rng, with_fext=True):
    """Our RNEA and ABA derivatives against Pinocchio's at one random state; {name: relative error}."""
    mp, pd = PinMap(model, pm), pm.createData()
    q, v, a = random_state(model, rng)
    tau = rng.normal(size=model.nv)
    F = rng.normal(size=(model.nbodies, 6)) if with_fext else None
    extra = (pin_forces(model, pm, F),) if with_fext else ()
    P = np.ix_(mp.v_perm, mp.v_perm)
    dq, dv, M = dynamics.inverse_dynamics_derivatives(model, q, v, a, f_ext=F)
    pin.computeRNEADerivatives(pm, pd, mp.q(q), mp.v(v), mp.v(a), *extra)
    err = {"dtau_dq": rel(dq, pd.dtau_dq[P]), "dtau_dv": rel(dv, pd.dtau_dv[P]), "M": rel(M, mp.M_back(pd.M))}
    da_dq, da_dv, Minv = dynamics.forward_dynamics_derivatives(model, q, v, tau, f_ext=F)
    pin.computeABADerivatives(pm, pd, mp.q(q), mp.v(v), mp.v(tau), *extra)
    err.update(da_dq=rel(da_dq, pd.ddq_dq[P]), da_dv=rel(da_dv, pd.ddq_dv[P]), Minv=rel(Minv, mp.M_back(pd.Minv)))
    return err


def assert_within(err, tol):
    bad = {k: e for k, e in err.items() if not e <= tol}
    assert not bad, f"relative errors above {tol}: {bad}"


@pytest.fixture(scope="module")
def panda():
    return dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")


@pytest.mark.parametrize("seed", range(6))
def test_random_trees_match_pinocchio(seed):
    """Trees mixing every joint type (revolute, continuous, prismatic, fixed, planar, spherical), with a URDF
    floating root, the floating_base option or a fixed base."""
    rng = np.random.default_rng(2000 + seed)
    text = random_urdf(rng, n_links=int(rng.integers(4, 12)), types=ALL_TYPES, floating_joint=seed % 3 == 0)
    floating = seed % 3 == 1
    model = dynamics.load_urdf(text, floating_base=floating)
    pm = pin_model(text, model, floating)
    assert_within(compare_with_pinocchio(model, pm, rng, with_fext=seed % 2 == 0), PIN_RTOL)


@pytest.mark.parametrize("rel_path, floating", [("panda_description/urdf/panda.urdf", False),
                                                ("ur_description/urdf/ur5_robot.urdf", True),
                                                ("anymal_c_simple_description/urdf/anymal.urdf", True)])
def test_robots_match_pinocchio(rel_path, floating):
    model = dynamics.load_urdf(erd(rel_path), floating_base=floating, mimic="independent", strict_inertia=False)
    pm = _pin_loads(erd(rel_path), floating)
    assert_within(compare_with_pinocchio(model, pm, np.random.default_rng(5)), PIN_RTOL)


@pytest.mark.slow
@pytest.mark.parametrize("rel_path", erd_urdfs())
@pytest.mark.parametrize("floating", [False, True], ids=["fixed", "floating"])
def test_every_example_robot_matches_pinocchio(rel_path, floating):
    pm = _pin_loads(erd(rel_path), floating)
    if pm is None:
        pytest.skip("Pinocchio does not load this URDF")
    try:
        model = dynamics.load_urdf(erd(rel_path), floating_base=floating, mimic="independent", strict_inertia=False)
    except dynamics.URDFError as e:
        pytest.skip(str(e))
    if model.nv == 0:
        return
    try:
        dynamics.inverse_mass_matrix(model, model.neutral())
    except dynamics.InputError:
        pytest.skip("M is singular (a joint that moves no mass)")
    assert_within(compare_with_pinocchio(model, pm, np.random.default_rng(abs(hash(rel_path)) % 2**32)), PIN_RTOL)


@pytest.mark.parametrize("floating", [False, True])
def test_finite_differences_on_the_manifold(floating):
    rng = np.random.default_rng(31 if floating else 32)
    model = dynamics.load_urdf(random_urdf(rng, n_links=7, types=ALL_TYPES), floating_base=floating)
    q, v, a = random_state(model, rng)
    tau = rng.normal(size=model.nv)
    F = rng.normal(size=(model.nbodies, 6))
    dq, dv, M = dynamics.inverse_dynamics_derivatives(model, q, v, a, f_ext=F)
    assert rel(dq, tangent_fd(lambda x: dynamics.inverse_dynamics(model, x, v, a, f_ext=F), model, q)) < FD_RTOL
    assert rel(dv, vector_fd(lambda x: dynamics.inverse_dynamics(model, q, x, a, f_ext=F), v)) < FD_RTOL
    assert rel(M, dynamics.mass_matrix(model, q)) < 1e-12
    da_dq, da_dv, Minv = dynamics.forward_dynamics_derivatives(model, q, v, tau, f_ext=F)
    assert rel(da_dq, tangent_fd(lambda x: dynamics.forward_dynamics(model, x, v, tau, f_ext=F), model, q)) < FD_RTOL
    assert rel(da_dv, vector_fd(lambda x: dynamics.forward_dynamics(model, q, x, tau, f_ext=F), v)) < FD_RTOL
    assert rel(Minv @ M, np.eye(model.nv)) < 1e-10


def test_a_batch_equals_its_single_states(panda):
    rng = np.random.default_rng(4)
    Q, V, A = (np.array(x) for x in zip(*(random_state(panda, rng) for _ in range(80))))
    dq, dv, M = dynamics.inverse_dynamics_derivatives(panda, Q, V, A)
    fq, fv, Minv = dynamics.forward_dynamics_derivatives(panda, Q, V, A)
    assert dq.shape == (80, panda.nv, panda.nv)
    for k in (0, 41, 79):
        for got, ref in zip((dq[k], dv[k], M[k]), dynamics.inverse_dynamics_derivatives(panda, Q[k], V[k], A[k])):
            np.testing.assert_array_equal(got, ref)
        for got, ref in zip((fq[k], fv[k], Minv[k]), dynamics.forward_dynamics_derivatives(panda, Q[k], V[k], A[k])):
            np.testing.assert_array_equal(got, ref)


def test_zero_velocity_derivatives_are_the_gravity_and_mass_terms(panda):
    """At v = 0 dtau/dv is zero (C(q, v) v is quadratic in v), and at v = a = 0 dtau/dq is dg/dq."""
    q = panda.neutral() + 0.3
    zero = np.zeros(panda.nv)
    dq, dv, _ = dynamics.inverse_dynamics_derivatives(panda, q, zero, zero)
    assert np.abs(dv).max() == 0.0
    assert rel(dq, vector_fd(lambda x: dynamics.gravity_torques(panda, x), q)) < FD_RTOL


def test_bad_inputs_name_the_argument(panda):
    q, v = panda.neutral(), np.zeros(panda.nv)
    with pytest.raises(dynamics.InputError, match="v"):
        dynamics.inverse_dynamics_derivatives(panda, q, np.zeros(3), v)
    with pytest.raises(dynamics.InputError, match="tau"):
        dynamics.forward_dynamics_derivatives(panda, q, v, np.full(panda.nv, np.nan))
    with pytest.raises(dynamics.InputError, match="f_ext"):
        dynamics.inverse_dynamics_derivatives(panda, q, v, v, f_ext=np.zeros((2, 6)))
    coupled = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))  # the fingers' mimic coupling
    with pytest.raises(dynamics.InputError, match="constraints"):
        dynamics.forward_dynamics_derivatives(coupled, coupled.neutral(), np.zeros(coupled.nv),
                                              np.zeros(coupled.nv))


def _minus_product(Minv, X):
    """-Minv X as the textbook loop sums it: each entry from +0, k in increasing order, o -= Minv[i, k] X[k, j]
    (Python floats are the kernel's doubles, so the bits are comparable)."""
    n = X.shape[0]
    A, B = Minv.tolist(), X.tolist()
    out = np.empty((n, n))
    for i in range(n):
        row = A[i]
        for j in range(n):
            o = 0.0
            for k in range(n):
                o -= row[k] * B[k][j]
            out[i, j] = o
    return out


@pytest.mark.parametrize("case", ["talos", "tree-floating", "tree-fext"])
def test_forward_derivatives_are_the_textbook_product_bit_for_bit(case):
    """core/aba_derivatives.cpp's product (register blocks, rows of zeros between branches left out, an AVX2 copy)
    gives the plain loop's bits: da/dq = -M^-1 dtau/dq and da/dv = -M^-1 dtau/dv at a = forward_dynamics(q, v,
    tau), with M^-1, a and dtau from the public functions, which compute them with the same operations."""
    rng = np.random.default_rng({"talos": 7, "tree-floating": 8, "tree-fext": 9}[case])
    F = g = None
    if case == "talos":
        model = dynamics.load_urdf(erd("talos_data/robots/talos_full_v2.urdf"), floating_base=True,
                                   mimic="independent")  # 50 coordinates, four limbs: many zero blocks
    else:
        model = dynamics.load_urdf(random_urdf(rng, n_links=13, types=ALL_TYPES, branching=0.6),
                                   floating_base=case == "tree-floating")
        if case == "tree-fext":
            F, g = rng.normal(size=(model.nbodies, 6)), rng.normal(size=3)
    q, v, _ = random_state(model, rng)
    tau = 5.0 * rng.normal(size=model.nv)
    da_dq, da_dv, Minv = dynamics.forward_dynamics_derivatives(model, q, v, tau, f_ext=F, gravity=g)
    a = dynamics.forward_dynamics(model, q, v, tau, f_ext=F, gravity=g)
    dtau_dq, dtau_dv, _ = dynamics.inverse_dynamics_derivatives(model, q, v, a, f_ext=F, gravity=g)
    np.testing.assert_array_equal(Minv, dynamics.inverse_mass_matrix(model, q))
    assert (dtau_dq == 0).any(), "no zero block: the test would not see rows left out"
    np.testing.assert_array_equal(da_dq, _minus_product(Minv, dtau_dq))
    np.testing.assert_array_equal(da_dv, _minus_product(Minv, dtau_dv))
    batch = dynamics.forward_dynamics_derivatives(model, q[None], v[None], tau[None],
                                                  f_ext=None if F is None else F[None], gravity=g)
    for got, ref in zip(batch, (da_dq, da_dv, Minv)):
        np.testing.assert_array_equal(got[0], ref)
