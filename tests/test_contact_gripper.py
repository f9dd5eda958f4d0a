"""A gripper holding a box (issue 19, section 5): Panda from example-robot-data (its collisions are meshes) with
a box pad declared on each finger, a free 0.1 kg box between them (``add_free_body``), the arm under PD with
gravity compensation and the fingers squeezing: box-box contact with friction.

Observables against the contact law: each pad presses with the finger's spring force; held (mu sum f_n > m g) the
box creeps no faster than regularised Coulomb friction allows (v_s m g / (mu sum f_n)); lifted 13 cm it stays in
the hand; with mu below m g / sum f_n it slips out."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dynamics
from robots import erd

HALF, MASS, G = 0.02, 0.1, 9.81  # the box: a 4 cm cube of 0.1 kg
KP_FINGER, SQUEEZE = 400.0, 0.01  # each finger's spring and how far inside the box its target is
FINGERS = ("panda_leftfinger", "panda_rightfinger")


@pytest.fixture(scope="module")
def grasp():
    arm = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), strict_inertia=False, mimic="independent")
    model = dynamics.add_free_body(arm, "object", dynamics.Box("object", (2 * HALF,) * 3), MASS)
    pad = np.eye(4)
    pad[2, 3] = 0.045  # 1 cm thick pads centred on the finger frames, 4.5 cm out along the fingers
    pads = [dynamics.Box(f, (0.02, 0.01, 0.02), pad, name=f + "_pad") for f in FINGERS]
    q = model.neutral().copy()
    q[:7] = [0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785]  # the hand pointing down
    q[7] = q[8] = HALF + 0.005  # the pads' inner faces touch the box's sides
    L, R = (dynamics.frame_placement(model, q, f) @ pad for f in FINGERS)
    q[9:12] = (L[:3, 3] + R[:3, 3]) / 2
    q[12:16] = Rotation.from_matrix(dynamics.frame_placement(model, q, "panda_hand")[:3, :3]).as_quat()
    tau_ff = dynamics.gravity_torques(model, q)
    tau_ff[9:] = 0.0  # the box is not actuated
    kp = np.r_[np.full(7, 400.0), KP_FINGER, KP_FINGER, np.zeros(6)]
    kd = np.r_[np.full(7, 20.0), 5.0, 5.0, np.zeros(6)]
    target = q.copy()
    target[7:9] -= SQUEEZE
    pd = dynamics.torques.PD(target, kp, kd, tau_ff=tau_ff)
    return model, q, pads, pd


def hold(grasp, mu, duration):
    model, q0, pads, pd = grasp
    contact = dynamics.Contact(geometries=[*pads, *model.collision_geometry], friction=mu)
    traj = dynamics.simulate(model, q0, np.zeros(model.nv), duration, torque=pd, contact=contact, rtol=1e-7,
                             atol=1e-9, error_estimate="none")
    assert traj.report["status"] == "ok"
    return model, contact, traj


def box_in_hand(model, q):
    H = dynamics.frame_placement(model, q, "panda_hand")
    return H[:3, :3].T @ (q[9:12] - H[:3, 3])


def test_held_box_creeps_no_faster_than_the_friction_law_allows(grasp):
    mu = 0.8
    model, contact, traj = hold(grasp, mu, 2.0)
    f_ext, det = dynamics.contact_forces(model, contact, traj.q[-1], traj.v[-1], details=True)
    sides = {f: sum(fn for fn, (a, b) in zip(det.normal_force, det.pairs) if a == f + "_pad") for f in FINGERS}
    assert len(det.normal_force) == 8  # four corners of each pad's face on the box
    for f, finger in zip(FINGERS, (7, 8)):  # each pad presses with its finger's spring force
        spring = KP_FINGER * (traj.q[-1, finger] - (grasp[1][finger] - SQUEEZE))
        assert sides[f] == pytest.approx(spring, rel=1e-3)
    total = sum(sides.values())
    assert mu * total > 5 * MASS * G  # well inside the friction cone
    i = np.searchsorted(traj.t, 1.0)
    creep = np.linalg.norm(box_in_hand(model, traj.q[-1]) - box_in_hand(model, traj.q[i])) / (traj.t[-1] - traj.t[i])
    allowed = contact.friction.stiction_velocity * MASS * G / (mu * total)
    assert creep <= allowed  # measured 8e-5 m/s against 1.5e-4 m/s
    assert np.linalg.norm(box_in_hand(model, traj.q[-1]) - box_in_hand(model, grasp[1])) < 1e-3


def test_lifted_box_stays_in_the_hand(grasp):
    """The shoulder's target raised by 0.3 rad (gravity compensation at the new posture): the hand rises 13 cm and
    the box moves by less than 0.5 mm in the hand (0.12 mm measured)."""
    model, q0, pads, pd = grasp
    target = pd.q_target.copy()
    target[1] -= 0.3
    tau_ff = dynamics.gravity_torques(model, target)
    tau_ff[9:] = 0.0
    kd = pd.kd.copy()
    kd[:7] = 40.0
    lift = dynamics.torques.PD(target, pd.kp, kd, tau_ff=tau_ff)
    contact = dynamics.Contact(geometries=[*pads, *model.collision_geometry], friction=0.8)
    traj = dynamics.simulate(model, q0, np.zeros(model.nv), 1.5, torque=lift, contact=contact, rtol=1e-7, atol=1e-9,
                             error_estimate="none")
    assert traj.report["status"] == "ok"
    rise = dynamics.frame_placement(model, traj.q[-1], "panda_hand")[2, 3] - dynamics.frame_placement(
        model, q0, "panda_hand")[2, 3]
    assert rise > 0.1
    assert np.linalg.norm(box_in_hand(model, traj.q[-1]) - box_in_hand(model, q0)) < 5e-4


def test_box_slips_out_when_friction_cannot_carry_it(grasp):
    mu = 0.1  # mu sum f_n = 0.8 N < m g = 0.98 N
    model, contact, traj = hold(grasp, mu, 0.3)
    slid = box_in_hand(model, traj.q[-1]) - box_in_hand(model, grasp[1])
    assert np.linalg.norm(slid) > 0.02 and traj.q[-1, 11] < grasp[1][11] - 0.02  # out of the hand, downwards
