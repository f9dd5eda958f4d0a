"""A humanoid standing (issue 19, section 5): Talos from example-robot-data (its collision geometry is meshes, so
box soles are declared in Python), the upper body locked (``lock_joints``), the legs under PD with gravity
compensation, on the default material: after 3 s the eight sole corners carry its weight (sum f_n = m g to 1e-5:
Hunt-Crossley damping is proportional to the penetration, 0.13 mm here, so the rocking on the soles decays slowly;
8e-7 measured), the soles do not creep and the robot keeps its height."""

import numpy as np
import pytest

import dynamics
from robots import erd

SOLES = ["left_sole_link", "right_sole_link"]
SOLE = (0.2, 0.1, 0.02)  # a box under each foot: its bottom face in the sole frame's z = 0 plane
HALF_SITTING = {"leg_left_3_joint": -0.411354, "leg_left_4_joint": 0.859395, "leg_left_5_joint": -0.448041,
                "leg_right_3_joint": -0.411354, "leg_right_4_joint": 0.859395, "leg_right_5_joint": -0.448041}
G = 9.81


@pytest.fixture(scope="module")
def talos():
    full = dynamics.load_urdf(erd("talos_data/robots/talos_reduced.urdf"), floating_base=True,
                              strict_inertia=False)
    upper = ("torso", "head", "arm", "gripper")
    model = dynamics.lock_joints(full, {n: 0.0 for n in full.joint_names if n.startswith(upper)})
    assert model.nv == 18
    q = model.neutral().copy()
    for name, angle in HALF_SITTING.items():
        q[model.q_index[model.joint_names.index(name)]] = angle
    mass = float(np.sum(model.tree.mass))
    pose = np.eye(4)
    pose[2, 3] = SOLE[2] / 2
    contact = dynamics.Contact(geometries=[dynamics.Box(s, SOLE, pose) for s in SOLES])
    k = mass * G / contact.friction.penetration_allowance  # the default stiffness of each contact point
    q[2] = -dynamics.frame_placement(model, q, SOLES[0])[2, 3] - mass * G / (8 * k)  # 8 corners share the weight
    # gravity compensation: sole wrenches balancing the weight about the base (least squares), the legs'
    # torques holding the pose under them
    g = dynamics.gravity_torques(model, q)
    J = [dynamics.frame_jacobian(model, q, s) for s in SOLES]
    w = np.linalg.lstsq(np.hstack([Js[:, :6].T for Js in J]), g[:6], rcond=None)[0]
    tau_ff = g - J[0].T @ w[:6] - J[1].T @ w[6:]
    assert np.abs(tau_ff[:6]).max() < 1e-9 * mass * G
    kp = np.r_[np.zeros(6), np.full(12, 3000.0)]  # above m g h (770 N m/rad at the ankles): no sway
    kd = np.r_[np.zeros(6), np.full(12, 100.0)]
    return model, q, mass, contact, dynamics.torques.PD(q.copy(), kp, kd, tau_ff=tau_ff)


@pytest.fixture(scope="module")
def standing(talos):
    model, q0, mass, contact, pd = talos
    return dynamics.simulate(model, q0, np.zeros(model.nv), 3.0, torque=pd, contact=contact, rtol=1e-8, atol=1e-10,
                             error_estimate="none")


def test_the_soles_carry_the_weight_at_rest(talos, standing):
    model, q0, mass, contact, pd = talos
    traj = standing
    assert traj.report["status"] == "ok"
    f_ext, det = dynamics.contact_forces(model, contact, traj.q[-1], traj.v[-1], details=True)
    assert len(det.normal_force) == 8  # the four bottom corners of each sole
    assert det.normal_force.sum() == pytest.approx(mass * G, rel=1e-5)
    assert np.abs(traj.v[-1]).max() < 1e-3
    i = np.searchsorted(traj.t, 2.5)
    for s in SOLES:  # no creep over the last half second
        slide = dynamics.frame_placement(model, traj.q[-1], s)[:2, 3] - dynamics.frame_placement(model, traj.q[i], s)[:2, 3]
        assert np.linalg.norm(slide) < 1e-5
    assert abs(traj.q[-1, 2] - q0[2]) < 1e-3  # it keeps its height
    c = traj.report["contact"]
    assert c["time_in_contact"] == pytest.approx(3.0)
    assert 0 < c["max_penetration"] < contact.friction.penetration_allowance
