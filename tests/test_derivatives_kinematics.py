"""Derivatives of frame kinematics, of the centre of mass and of the configuration update, against Pinocchio
(getFrameVelocityDerivatives, getFrameAccelerationDerivatives, getFrameJacobianTimeVariation,
getCenterOfMassVelocityDerivatives, dIntegrate, dDifference; 1e-9) and central finite differences on the
manifold (1e-6 at step 1e-7).

Every joint type (spherical and planar included) against finite differences and in the configuration
Jacobians against Pinocchio; frame derivatives against Pinocchio on 1-dof joints and a free base (the test says
why).  Pinocchio's "local_world_aligned" q derivatives hold the point fixed in the world where ours follow the frame
origin (ours are the derivatives of dynamics.frame_velocity / frame_acceleration, which finite differences
confirm): the two differ by exactly do_f/dq x w, checked as such.
"""

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from robots import ALL_TYPES, random_state, random_urdf
from test_derivatives import STEP, rel, tangent_fd, vector_fd
from test_kinematics_pinocchio import pin_frame_ids
from test_pinocchio import PinMap, pin_model

REFS = {"world": pin.WORLD, "local": pin.LOCAL, "local_world_aligned": pin.LOCAL_WORLD_ALIGNED}
PIN_TOL = 1e-9
FD_TOL = 1e-6


def tree(seed, floating, types=ALL_TYPES):
    rng = np.random.default_rng(seed)
    text = random_urdf(rng, n_links=7, types=types)
    model = dynamics.load_urdf(text, floating_base=floating)
    return model, pin_model(text, model, floating), rng


def deepest_frame(model):
    """A frame on the body with the longest support (the most columns to get right)."""
    depth = np.zeros(model.nbodies, int)
    for i in range(model.nbodies):
        par = model.tree.parents[i]
        depth[i] = 1 + (depth[par] if par >= 0 else 0)
    body = int(np.argmax(depth))
    return next(f for f in range(len(model.frame_names)) if model.frame_arrays.body[f] == body
                and not np.array_equal(model.frame_arrays.p[f], 0.0))


def origin_motion_term(model, q, frame, w):
    """do_f/dq x w (3, nv): what Pinocchio's local_world_aligned q derivative leaves out."""
    J = dynamics.frame_jacobian(model, q, frame, reference="local_world_aligned")
    return -np.cross(w, J[:3].T).T


@pytest.mark.parametrize("seed, floating", [(1, False), (2, True)])
def test_frame_derivatives_match_pinocchio(seed, floating):
    """1-dof joints and a free base.  (With spherical and planar joints Pinocchio's acceleration q derivatives
    differ from ours in those joints' columns, where finite differences confirm ours: see the next test; its
    dynamics derivatives agree with ours on every joint type, tests/test_derivatives.py.)"""
    model, pm, rng = tree(seed, floating, ("revolute", "continuous", "prismatic", "fixed"))
    mp, pd = PinMap(model, pm), pm.createData()
    q, v, a = random_state(model, rng)
    f = deepest_frame(model)
    fid = pin_frame_ids(model, pm)[f]
    pin.computeForwardKinematicsDerivatives(pm, pd, mp.q(q), mp.v(v), mp.v(a))
    pin.updateFramePlacements(pm, pd)
    pin.computeJointJacobiansTimeVariation(pm, pd, mp.q(q), mp.v(v))
    for ref, pref in REFS.items():
        ours = dynamics.frame_acceleration_derivatives(model, q, v, a, f, reference=ref)
        theirs = [x[:, mp.v_perm] for x in pin.getFrameAccelerationDerivatives(pm, pd, fid, pref)]
        if ref == "local_world_aligned":  # Pinocchio holds the point fixed (module docstring)
            vel = dynamics.frame_velocity(model, q, v, f, reference=ref)
            acc = dynamics.frame_acceleration(model, q, v, a, f, reference=ref, classical=False)
            theirs[0][:3] -= origin_motion_term(model, q, f, vel[3:])
            theirs[1][:3] -= origin_motion_term(model, q, f, acc[3:])
        for name, x, y in zip(("dv_dq", "da_dq", "da_dv", "da_da"), ours, theirs):
            assert rel(x, y) < PIN_TOL, (ref, name)
        dv = dynamics.frame_velocity_derivatives(model, q, v, f, reference=ref)
        np.testing.assert_array_equal(dv[0], ours[0])
        assert rel(dv[1], theirs[3]) < PIN_TOL
        dJ = dynamics.frame_jacobian_time_variation(model, q, v, f, reference=ref)
        assert rel(dJ, pin.getFrameJacobianTimeVariation(pm, pd, fid, pref)[:, mp.v_perm]) < PIN_TOL
    pin.centerOfMass(pm, pd, mp.q(q), mp.v(v))
    dcom, dvcom = dynamics.center_of_mass_derivatives(model, q, v)
    assert rel(dcom, pin.jacobianCenterOfMass(pm, pd, mp.q(q))[:, mp.v_perm]) < PIN_TOL
    pin.computeForwardKinematicsDerivatives(pm, pd, mp.q(q), mp.v(v), mp.v(a))
    pin.centerOfMass(pm, pd, mp.q(q), mp.v(v))
    assert rel(dvcom, pin.getCenterOfMassVelocityDerivatives(pm, pd)[:, mp.v_perm]) < PIN_TOL


@pytest.mark.parametrize("ref", list(REFS))
def test_frame_derivatives_are_the_finite_differences(ref):
    model, _, rng = tree(3, True)
    q, v, a = random_state(model, rng)
    f = deepest_frame(model)
    dv_dq, da_dq, da_dv, da_da = dynamics.frame_acceleration_derivatives(model, q, v, a, f, reference=ref)

    def acc(q_, v_, a_):
        return dynamics.frame_acceleration(model, q_, v_, a_, f, reference=ref, classical=False)

    assert rel(dv_dq, tangent_fd(lambda x: dynamics.frame_velocity(model, x, v, f, reference=ref), model, q)) < FD_TOL
    assert rel(da_dq, tangent_fd(lambda x: acc(x, v, a), model, q)) < FD_TOL
    assert rel(da_dv, vector_fd(lambda x: acc(q, x, a), v)) < FD_TOL
    assert rel(da_da, dynamics.frame_jacobian(model, q, f, reference=ref)) < 1e-12
    # dJ/dt: the Jacobian along q(t) = q (+) t v
    dJ = dynamics.frame_jacobian_time_variation(model, q, v, f, reference=ref)

    def jac_along(t):
        return dynamics.frame_jacobian(model, dynamics.integrate(model, q, v, t), f, reference=ref)

    assert rel(dJ, (jac_along(STEP) - jac_along(-STEP)) / (2 * STEP)) < FD_TOL
    dcom, dvcom = dynamics.center_of_mass_derivatives(model, q, v)
    assert rel(dvcom, tangent_fd(lambda x: dynamics.center_of_mass_velocity(model, x, v), model, q)) < FD_TOL


@pytest.mark.parametrize("floating", [False, True])
def test_configuration_jacobians_match_pinocchio_and_finite_differences(floating):
    model, pm, rng = tree(4, floating)
    mp = PinMap(model, pm)
    q0, v, _ = random_state(model, rng)
    q1, _, _ = random_state(model, rng)
    P = np.ix_(mp.v_perm, mp.v_perm)
    Jq, Jv = dynamics.integrate_jacobians(model, q0, v)
    assert rel(Jq, pin.dIntegrate(pm, mp.q(q0), mp.v(v), pin.ARG0)[P]) < PIN_TOL
    assert rel(Jv, pin.dIntegrate(pm, mp.q(q0), mp.v(v), pin.ARG1)[P]) < PIN_TOL
    d = dynamics.difference(model, q0, q1)
    gap = d - mp.v_back(pin.difference(pm, mp.q(q0), mp.q(q1)))
    # a continuous joint's angle is ours unwrapped (integrate(q0, d) == q1 exactly), Pinocchio's in (-pi, pi]
    assert np.abs(np.angle(np.exp(1j * gap))).max() < PIN_TOL
    assert rel(dynamics.difference(model, q1, dynamics.integrate(model, q0, d)), np.zeros(model.nv)) < PIN_TOL
    J0, J1 = dynamics.difference_jacobians(model, q0, q1)
    assert rel(J0, pin.dDifference(pm, mp.q(q0), mp.q(q1), pin.ARG0)[P]) < PIN_TOL
    assert rel(J1, pin.dDifference(pm, mp.q(q0), mp.q(q1), pin.ARG1)[P]) < PIN_TOL
    # finite differences on the manifold: the result of integrate compared through difference
    base = dynamics.integrate(model, q0, v)
    assert rel(Jq, tangent_fd(lambda x: dynamics.difference(model, base, dynamics.integrate(model, x, v)),
                              model, q0)) < FD_TOL
    assert rel(Jv, vector_fd(lambda x: dynamics.difference(model, base, dynamics.integrate(model, q0, x)), v)) < FD_TOL
    assert rel(J1, tangent_fd(lambda x: dynamics.difference(model, q0, x), model, q1)) < FD_TOL
    assert rel(J0, tangent_fd(lambda x: dynamics.difference(model, x, q1), model, q0)) < FD_TOL
