"""The 6-6 Stewart platform (robots/stewart_platform.urdf; issue 10, sections 3 and 4).

* Geometry: the file's anchors against the formulas its header states; the home pose (model.neutral()) closes
  the six ball joints; the reported rows, rank and mobility.
* Assembly against the closed-form inverse kinematics of a Stewart platform, leg length = |x + R p_K - b_K|:
  with the platform pose fixed, ``assemble`` finds the legs; with the six strokes fixed, it finds the
  platform pose back (forward kinematics).
* Constrained forward dynamics and multipliers against Pinocchio's ``constraintDynamics`` with six
  RigidConstraintModel CONTACT_3D closures (LOCAL_WORLD_ALIGNED, the convention of our rows).
* Constrained inverse dynamics with the six prismatic actuators: passive joints get no torque, and both our and
  Pinocchio's forward dynamics turn the torques back into the motion.
* Rank and redundancy: a duplicated ball joint (3 redundant rows) keeps the accelerations and halves the
  multipliers (minimum norm); locking the actuators leaves a rigid structure, refused with the rank.
"""

import os

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from robots import OUR_ROBOTS
from test_pinocchio import PinMap

PATH = os.path.join(OUR_ROBOTS, "stewart_platform.urdf")
ACTUATORS = [f"leg{k}_actuator" for k in range(1, 7)]
TOL = 1e-9  # relative to the largest entry, as tests/test_constraints_pinocchio.py

# the geometry stated in the file's header
R_B, R_P, H = 0.5, 0.3, 0.6


def base_point(k):
    j, sign = (k - 1) // 2, (1 if k % 2 == 0 else -1)
    t = np.radians(120 * j + sign * 15)
    return np.array([R_B * np.cos(t), R_B * np.sin(t), 0.0])


def platform_point(k):
    j, sign = (k - 1) // 2, (1 if k % 2 == 0 else -1)
    u = np.radians(120 * j + sign * 45)
    return np.array([R_P * np.cos(u), R_P * np.sin(u), 0.0])


HOME_LENGTH = np.linalg.norm(np.array([0, 0, H]) + platform_point(1) - base_point(1))


@pytest.fixture(scope="module")
def model():
    return dynamics.load_urdf(PATH)


def rel(x, ref):
    return np.abs(np.asarray(x) - ref).max() / max(np.abs(ref).max(), 1.0)


def quat_xyzw(rotvec):
    angle = np.linalg.norm(rotvec)
    axis = rotvec / angle if angle > 0 else np.zeros(3)
    return np.r_[np.sin(angle / 2) * axis, np.cos(angle / 2)]


def rotation(quat):
    x, y, z, w = quat
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def platform_pose(rng):
    """platform_joint's q near home: [x, quaternion], the platform frame at (0, 0, H) + x turned by R (a few
    cm, a few degrees)."""
    return np.r_[rng.uniform(-0.05, 0.05, 3), quat_xyzw(rng.uniform(-0.1, 0.1, 3))]


def leg_lengths(pose):
    """Closed-form inverse kinematics: |(0, 0, H) + x + R p_K - b_K| for K = 1..6."""
    R = rotation(pose[3:])
    return np.array([np.linalg.norm([0, 0, H] + pose[:3] + R @ platform_point(k) - base_point(k))
                     for k in range(1, 7)])


def closed_state(model, rng):
    """q with the platform at a random pose near home and the legs assembled to it, a v the loops allow."""
    pose = platform_pose(rng)
    q = dynamics.assemble(model, model.neutral(), fixed={"platform_joint": pose})
    v = dynamics.project_velocity(model, q, rng.normal(size=model.nv))
    return q, v


def test_geometry_home_pose_and_rank(model):
    assert (model.nq, model.nv) == (25, 24)
    assert model.info["constraints"] == {"count": 6, "rows": 18, "rank": 18, "mobility": 6,
                                         "closed_near_assembly": True}
    home = model.neutral()
    np.testing.assert_array_equal(home[:7], [0, 0, 0, 0, 0, 0, 1])
    np.testing.assert_allclose(dynamics.frame_placement(model, home, "platform")[:3, 3], [0, 0, H], atol=1e-15)
    for k, con in enumerate(model.constraints, 1):
        assert (con.frame_a, con.frame_b) == (f"leg{k}_piston", "platform")
        np.testing.assert_allclose(con.point_b, platform_point(k), atol=1e-15)
        np.testing.assert_allclose(con.point_a, [0, 0, HOME_LENGTH], atol=1e-15)
        np.testing.assert_allclose(dynamics.frame_placement(model, home, f"leg{k}_cross")[:3, 3], base_point(k),
                                   atol=1e-15)
    assert np.abs(dynamics.constraint_residual(model, home)).max() < 1e-15
    q = dynamics.assemble(model, home)
    assert np.abs(dynamics.constraint_residual(model, q)).max() <= 1e-12
    np.testing.assert_allclose(q, home, atol=1e-14)


def test_assembly_against_closed_form_leg_lengths(model):
    rng = np.random.default_rng(1)
    strokes = [model.q_index[model.joint_index(n)] for n in ACTUATORS]
    for _ in range(3):
        pose = platform_pose(rng)
        q = dynamics.assemble(model, model.neutral(), fixed={"platform_joint": pose})  # legs from the platform
        assert np.abs(dynamics.constraint_residual(model, q)).max() <= 1e-12
        np.testing.assert_allclose(HOME_LENGTH + q[strokes], leg_lengths(pose), atol=1e-12)
        # forward kinematics: the six strokes alone put the platform back where it was
        fk = dynamics.assemble(model, model.neutral(), fixed={n: q[i] for n, i in zip(ACTUATORS, strokes)})
        np.testing.assert_allclose(fk[:3], pose[:3], atol=1e-10)
        np.testing.assert_allclose(rotation(fk[3:7] / np.linalg.norm(fk[3:7])), rotation(pose[3:]), atol=1e-10)


def pinocchio_closures(model):
    """Pinocchio's model of the same file and six CONTACT_3D RigidConstraintModels of the ball joints."""
    pm = pin.buildModelFromUrdf(PATH)
    cm, cd = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for con in model.constraints:
        fa, fb = pm.frames[pm.getFrameId(con.frame_a)], pm.frames[pm.getFrameId(con.frame_b)]
        rcm = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, pm,
                                       fa.parentJoint, fa.placement * pin.SE3(np.eye(3), np.array(con.point_a)),
                                       fb.parentJoint, fb.placement * pin.SE3(np.eye(3), np.array(con.point_b)),
                                       pin.LOCAL_WORLD_ALIGNED)
        cm.append(rcm)
        cd.append(rcm.createData())
    pd = pm.createData()
    pin.initConstraintDynamics(pm, pd, cm, cd)
    return pm, pd, cm, cd


def pin_forward(pin_side, mp, q, v, tau):
    pm, pd, cm, cd = pin_side
    a = pin.constraintDynamics(pm, pd, mp.q(q), mp.v(v), mp.v(tau), cm, cd, pin.ProximalSettings(1e-14, 0.0, 1))
    return mp.v_back(a), np.array(pd.lambda_c)


def test_forward_dynamics_matches_pinocchio(model):
    pin_side = pinocchio_closures(model)
    mp = PinMap(model, pin_side[0])
    rng = np.random.default_rng(2)
    states = [closed_state(model, rng) for _ in range(4)]
    Q, V = np.array([s[0] for s in states]), np.array([s[1] for s in states])
    T = rng.normal(scale=20.0, size=(len(states), model.nv))
    A, LAM = dynamics.constrained_forward_dynamics(model, Q, V, T)  # the batched path
    for b, (q, v) in enumerate(states):
        a, lam = dynamics.constrained_forward_dynamics(model, q, v, T[b])  # the single-state path
        a_pin, lam_pin = pin_forward(pin_side, mp, q, v, T[b])
        assert rel(a, a_pin) < TOL, (a, a_pin)
        assert rel(lam, lam_pin) < TOL, (lam, lam_pin)
        np.testing.assert_allclose(A[b], a, rtol=0, atol=1e-12 * max(1, np.abs(a).max()))
        np.testing.assert_allclose(LAM[b], lam, rtol=0, atol=1e-12 * max(1, np.abs(lam).max()))
        # the loops' accelerations hold: Phi_q a + Phi_q_dot v = 0
        J, gamma = dynamics.constraint_jacobian(model, q), dynamics.constraint_bias(model, q, v)
        assert np.abs(J @ a + gamma).max() < 1e-9 * max(1, np.abs(gamma).max())


def test_actuator_forces_from_inverse_dynamics_reproduce_the_motion(model):
    pin_side = pinocchio_closures(model)
    mp = PinMap(model, pin_side[0])
    rng = np.random.default_rng(3)
    passive = [model.v_index[model.joint_index(n)] for n in model.joint_names if n not in ACTUATORS]
    passive += list(range(6))  # the free platform's six velocity coordinates
    for _ in range(2):
        q, v = closed_state(model, rng)
        a, _ = dynamics.constrained_forward_dynamics(model, q, v, rng.normal(scale=20.0, size=model.nv))
        tau = dynamics.constrained_inverse_dynamics(model, q, v, a, actuated=ACTUATORS)
        assert np.all(tau[passive] == 0.0)
        a_ours, _ = dynamics.constrained_forward_dynamics(model, q, v, tau)
        a_pin, _ = pin_forward(pin_side, mp, q, v, tau)
        np.testing.assert_allclose(a_ours, a, rtol=0, atol=1e-8 * max(1, np.abs(a).max()))
        np.testing.assert_allclose(a_pin, a, rtol=0, atol=1e-8 * max(1, np.abs(a).max()))
    # holding the platform still at home: the six equal actuator forces (the home pose is symmetric under the
    # 120 deg turns and the mirror that swap legs) carry the weight
    home = model.neutral()
    tau = dynamics.constrained_inverse_dynamics(model, home, np.zeros(model.nv), np.zeros(model.nv),
                                                actuated=ACTUATORS)
    f = tau[[model.v_index[model.joint_index(n)] for n in ACTUATORS]]
    np.testing.assert_allclose(f, f[0], rtol=1e-9)
    assert f[0] > 0.0  # pushing up
    # five actuators cannot produce a general motion of a 6-dof platform
    q, v = closed_state(model, rng)
    a, _ = dynamics.constrained_forward_dynamics(model, q, v, rng.normal(scale=20.0, size=model.nv))
    with pytest.raises(dynamics.InputError, match="cannot produce this motion"):
        dynamics.constrained_inverse_dynamics(model, q, v, a, actuated=ACTUATORS[:5])


def test_redundant_ball_joint_and_locked_actuators(model):
    """A second copy of ball joint 1 adds 3 dependent rows: rank 18 of 21 reported, the same accelerations,
    and the minimum-norm multipliers split ball 1's force evenly between the two copies."""
    twice = dynamics.with_constraints(model, [model.constraints[0]])
    assert twice.info["constraints"] == {"count": 7, "rows": 21, "rank": 18, "mobility": 6,
                                         "closed_near_assembly": True}
    rng = np.random.default_rng(4)
    q, v = closed_state(model, rng)
    tau = rng.normal(scale=20.0, size=model.nv)
    a1, lam1 = dynamics.constrained_forward_dynamics(model, q, v, tau)
    a2, lam2 = dynamics.constrained_forward_dynamics(twice, q, v, tau)
    np.testing.assert_allclose(a2, a1, rtol=0, atol=1e-9 * np.abs(a1).max())
    expect = np.r_[lam1[:3] / 2, lam1[3:], lam1[:3] / 2]
    np.testing.assert_allclose(lam2, expect, rtol=0, atol=1e-9 * np.abs(lam1).max())
    # and the lectures' formula with numpy's pseudo-inverse of the singular Delassus matrix K = J M^-1 J^T
    J, gamma = dynamics.constraint_jacobian(twice, q), dynamics.constraint_bias(twice, q, v)
    M = dynamics.mass_matrix(model, q)
    f = tau - dynamics.inverse_dynamics(model, q, v, np.zeros(model.nv))
    K = J @ np.linalg.solve(M, J.T)
    lam_ref = np.linalg.pinv(K, rcond=1e-12, hermitian=True) @ -(J @ np.linalg.solve(M, f) + gamma)
    np.testing.assert_allclose(lam2, lam_ref, rtol=0, atol=1e-9 * np.abs(lam_ref).max())
    np.testing.assert_allclose(a2, np.linalg.solve(M, f + J.T @ lam_ref), rtol=0, atol=1e-9 * np.abs(a1).max())
    # the actuators locked: 18 independent rows on 18 coordinates, nothing can move
    with pytest.raises(dynamics.InputError, match=r"over-constrained.*rank 18 = nv = 18"):
        dynamics.lock_joints(model, {n: 0.0 for n in ACTUATORS})
