"""Operational-space control (issue 9, section 2): dynamics.torques.OperationalSpace and Target.

The closed loop of the model under its own operational-space controller is e'' + Kd e' + Kp e = 0 in the task
rows, so a reference started on the path is tracked to the integrator's accuracy; the torque itself is
checked against the textbook form tau = J^T (Lambda xdd* + mu + p) + N tau_0 built from explicit matrices.
"""

import numpy as np
import pytest

import dynamics
from dynamics.torques import ComputedTorque, OperationalSpace, Target, TaskReference
from robots import ALL_TYPES, OUR_ROBOTS, erd, random_urdf

PANDA_Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8, 0.02, 0.02])


@pytest.fixture(scope="module")
def arm2():
    return dynamics.load_urdf(f"{OUR_ROBOTS}/planar_2r.urdf")


@pytest.fixture(scope="module")
def panda():
    """The open tree (fingers independent): the controller models the tree's dynamics, and these tests check
    that it tracks them to 1e-6.  With the default mimic coupling simulate integrates the coupled fingers,
    whose coupling force the controller does not model (the hand then tracks to ~3e-5 m)."""
    return dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")


def circle(t, centre, r, w, u=(1.0, 0.0, 0.0), n=(0.0, 0.0, 1.0)):
    """centre + r (cos(wt) u + sin(wt) n) and its first two time derivatives, (len(t), 3) each."""
    u, n, c, s = np.asarray(u), np.asarray(n), np.cos(w * t)[:, None], np.sin(w * t)[:, None]
    return centre + r * (c * u + s * n), r * w * (-s * u + c * n), -r * w * w * (c * u + s * n)


def tip_position(model, frame, Q):
    return dynamics.forward_kinematics(model, Q)[:, model.frame_index(frame), :3, 3]


# -- the lectures' 2R arm on a circle, against the joint-space computed torque -------------------------------
def test_2r_tracks_the_circle_like_computed_torque(arm2):
    """x = a + r cos(wt), y = b + r sin(wt) in the arm's plane (world x-z) for 10 s, within 1e-6 m."""
    T, a, b, r, w = 10.0, 1.0, 0.6, 0.3, 2 * np.pi / 10.0
    t = np.arange(0.0, T + 1e-9, 1e-2)
    p, pd, pdd = circle(t, np.array([a, 0.0, b]), r, w)
    q2 = np.arccos((np.hypot(p[:, 0], p[:, 2]) ** 2 - 2.0) / 2.0)  # elbow-down inverse kinematics
    q = np.stack([np.arctan2(p[:, 2], p[:, 0]) - np.arctan2(np.sin(q2), 1 + np.cos(q2)), q2], 1)
    Jp = dynamics.frame_jacobian(arm2, q, "tip")[:, [0, 2]]
    v = np.linalg.solve(Jp, pd[:, [0, 2], None])[..., 0]
    acc = np.linalg.solve(Jp, (pdd - dynamics.frame_bias_acceleration(arm2, q, v, "tip")[:, :3])[:, [0, 2], None])[..., 0]
    kw = dict(rtol=1e-10, atol=1e-12, sample_dt=0.05)
    os_ = dynamics.simulate(arm2, q[0], v[0], T, torque=OperationalSpace("tip", TaskReference(t, p, pd, pdd),
                                                                         kp=100.0, kd=20.0, rows=[0, 2]), **kw)
    ct = dynamics.simulate(arm2, q[0], v[0], T, torque=ComputedTorque(t, q, v, acc, kp=100.0, kd=20.0), **kw)
    exact = circle(os_.t, np.array([a, 0.0, b]), r, w)[0]
    err_os = np.abs(tip_position(arm2, "tip", os_.q) - exact).max()
    err_ct = np.abs(tip_position(arm2, "tip", ct.q) - exact).max()
    assert os_.report["status"] == "ok" and err_os < 1e-6 and err_ct < 1e-6, (err_os, err_ct)
    # same torques: both controllers command the same motion
    assert np.abs(os_.tau - ct.tau).max() < 1e-6 * np.abs(ct.tau).max()


def test_2r_positions_only_reference_uses_finite_differences(arm2):
    """Given only positions, velocities and accelerations come from central differences (O(h^2))."""
    T, w = 2.0, np.pi
    t = np.arange(0.0, T + 1e-9, 1e-3)
    p, pd, _ = circle(t, np.array([1.0, 0.0, 0.6]), 0.3, w)
    q2 = np.arccos((np.hypot(p[0, 0], p[0, 2]) ** 2 - 2.0) / 2.0)
    q0 = np.array([np.arctan2(p[0, 2], p[0, 0]) - np.arctan2(np.sin(q2), 1 + np.cos(q2)), q2])
    v0 = np.linalg.solve(dynamics.frame_jacobian(arm2, q0, "tip")[[0, 2]], pd[0, [0, 2]])
    tr = dynamics.simulate(arm2, q0, v0, T, torque=OperationalSpace("tip", (t, p), kp=100.0, kd=20.0, rows=[0, 2]),
                           rtol=1e-10, atol=1e-12, sample_dt=0.05)
    err = np.abs(tip_position(arm2, "tip", tr.q) - circle(tr.t, np.array([1.0, 0.0, 0.6]), 0.3, w)[0]).max()
    assert err < 1e-5


# -- the torque against the textbook form built from explicit matrices --------------------------------------
def test_torque_is_the_textbook_operational_space_law(panda):
    """tau = J^T (Lambda xdd* + Lambda (J M^-1 b - Jdot v)) + (1 - J^T Lambda J M^-1) (tau_p + b), with b the
    bias forces minus the passive (damping) torques, at the samples of a short run toward a fixed pose."""
    R0 = dynamics.frame_placement(panda, PANDA_Q0, "panda_hand")
    target = R0[:3, 3] + [0.05, -0.03, 0.04]
    kp, kd, kp0 = np.array([50.0, 60, 70, 30, 40, 50]), 15.0, 9.0
    src = Target("panda_hand", target, R0[:3, :3], kp=kp, kd=kd, posture=PANDA_Q0, posture_kp=kp0)
    tr = dynamics.simulate(panda, PANDA_Q0, np.zeros(9), 0.3, torque=src, rtol=1e-9, atol=1e-11, sample_dt=0.1)
    for q, v, tau in zip(tr.q, tr.v, tr.tau):
        J = dynamics.frame_jacobian(panda, q, "panda_hand")
        Minv = dynamics.inverse_mass_matrix(panda, q)
        b = dynamics.bias_forces(panda, q, v) + panda.damping * v
        Lam = np.linalg.inv(J @ Minv @ J.T)
        T = dynamics.frame_placement(panda, q, "panda_hand")
        dR = R0[:3, :3] @ T[:3, :3].T
        angle = np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1))  # log(dR) = angle * axis, angle < pi here
        sin_axis = np.array([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]]) / 2
        e = np.concatenate([target - T[:3, 3], sin_axis * (angle / np.sin(angle) if angle > 1e-12 else 1.0)])
        xdd = kp * e - kd * (J @ v)
        mu_p = Lam @ (J @ Minv @ b - dynamics.frame_bias_acceleration(panda, q, v, "panda_hand"))
        N = np.eye(9) - J.T @ Lam @ J @ Minv
        kd0 = 2 * np.sqrt(kp0 * np.diag(dynamics.mass_matrix(panda, PANDA_Q0)))
        tau0 = kp0 * (PANDA_Q0 - q) - kd0 * v + b
        expected = J.T @ (Lam @ xdd + mu_p) + N @ tau0
        assert np.abs(tau - expected).max() < 1e-7 * np.abs(expected).max()


def test_quaternion_joints_without_a_posture():
    """A fixed base with spherical joints and no posture task: the posture reference is the neutral
    configuration (a zero quaternion gave NaN torques), and the torque is the textbook law with tau_p = 0,
    tau = J^T Lambda (xdd* + J M^-1 b - Jdot v) + N b."""
    for seed in range(100):
        model = dynamics.load_urdf(random_urdf(np.random.default_rng(seed), 6, types=ALL_TYPES))
        if "spherical" in model.joint_types:
            break
    rng = np.random.default_rng(0)
    q0 = dynamics.integrate(model, model.neutral(), 0.3 * rng.normal(size=model.nv))
    frame = max(model.frame_names, key=lambda f: np.linalg.matrix_rank(
        dynamics.frame_jacobian(model, q0, f, reference="local_world_aligned")[:3], tol=1e-3))
    target = dynamics.frame_placement(model, q0, frame)[:3, 3] + [0.02, -0.01, 0.01]
    tr = dynamics.simulate(model, q0, np.zeros(model.nv), 0.02, torque=Target(frame, target, kp=50.0, kd=10.0),
                           integrator="rk4", dt=1e-3, sample_dt=0.005)  # rk4: a third of auto's compile time
    assert tr.report["status"] == "ok" and np.isfinite(tr.tau).all()
    for q, v, tau in zip(tr.q, tr.v, tr.tau):
        J = dynamics.frame_jacobian(model, q, frame, reference="local_world_aligned")[:3]
        Minv = dynamics.inverse_mass_matrix(model, q)
        b = dynamics.bias_forces(model, q, v) + model.damping * v
        Lam = np.linalg.inv(J @ Minv @ J.T)
        p = dynamics.frame_placement(model, q, frame)[:3, 3]
        xdd = 50.0 * (target - p) - 10.0 * (J @ v)
        jdv = dynamics.frame_bias_acceleration(model, q, v, frame)[:3]
        expected = J.T @ Lam @ (xdd + J @ Minv @ b - jdv) + (np.eye(model.nv) - J.T @ Lam @ J @ Minv) @ b
        assert np.abs(tau - expected).max() < 1e-7 * np.abs(expected).max()


# -- Panda: a 10 cm circle, the posture held in the null space ----------------------------------------------
@pytest.mark.parametrize("rows", [3, 6])
def test_panda_tracks_a_circle_with_bounded_posture(panda, rows):
    """Position (3 rows) or position and a fixed orientation (6 rows): within 1e-6 m (and rad); the 6 or 3 free
    directions of the 9 joints are held near the start by the posture task."""
    T0 = dynamics.frame_placement(panda, PANDA_Q0, "panda_hand")
    T, r, w = 4.0, 0.1, 2 * np.pi / 4.0
    t = np.arange(0.0, T + 1e-9, 1e-2)
    centre = T0[:3, 3] - [r, 0.0, 0.0]  # the circle starts at the hand
    p, pd, pdd = circle(t, centre, r, w, u=(1.0, 0.0, 0.0), n=(0.0, 1.0, 0.0))
    v0 = np.linalg.lstsq(dynamics.frame_jacobian(panda, PANDA_Q0, "panda_hand")[:3], pd[0], rcond=None)[0]
    ref = TaskReference(t, p, pd, pdd, orientation=T0[:3, :3] if rows == 6 else None)
    src = OperationalSpace("panda_hand", ref, kp=100.0, kd=20.0, posture=PANDA_Q0, posture_kp=25.0)
    if rows == 6:
        v0 = np.linalg.lstsq(dynamics.frame_jacobian(panda, PANDA_Q0, "panda_hand"),
                             np.concatenate([pd[0], np.zeros(3)]), rcond=None)[0]
    tr = dynamics.simulate(panda, PANDA_Q0, v0, T, torque=src, rtol=1e-10, atol=1e-12, sample_dt=0.05)
    assert tr.report["status"] == "ok"
    P = dynamics.forward_kinematics(panda, tr.q)[:, panda.frame_index("panda_hand")]
    assert np.abs(P[:, :3, 3] - circle(tr.t, centre, r, w, n=(0.0, 1.0, 0.0))[0]).max() < 1e-6
    if rows == 6:
        assert np.abs(P[:, :3, :3] - T0[:3, :3]).max() < 1e-6
    # the posture stays bounded (the shoulder and wrist share the 20 cm excursion by stiffness: ~0.6 rad at most)
    # and is back once the hand is; the fingers, outside the task, are held by the posture against the hand's
    # accelerations
    assert np.abs(tr.q - PANDA_Q0).max() < 0.75 and np.abs(tr.v).max() < 1.5
    assert np.abs(tr.q[-1] - PANDA_Q0).max() < 0.05 and np.abs(tr.q[:, 7:] - PANDA_Q0[7:]).max() < 1e-3


def test_target_converges_to_a_fixed_pose(panda):
    T0 = dynamics.frame_placement(panda, PANDA_Q0, "panda_hand")
    Rz = np.array([[np.cos(0.3), -np.sin(0.3), 0], [np.sin(0.3), np.cos(0.3), 0], [0, 0, 1]])
    target_p, target_R = T0[:3, 3] + [0.05, 0.05, -0.05], Rz @ T0[:3, :3]
    src = Target("panda_hand", target_p, target_R, kp=100.0, kd=20.0, posture=PANDA_Q0, posture_kp=10.0)
    tr = dynamics.simulate(panda, PANDA_Q0, np.zeros(9), 3.0, torque=src, rtol=1e-9, atol=1e-11, sample_dt=0.5)
    Tf = dynamics.frame_placement(panda, tr.q[-1], "panda_hand")
    assert np.abs(Tf[:3, 3] - target_p).max() < 1e-6 and np.abs(Tf[:3, :3] - target_R).max() < 1e-6
    assert np.abs(tr.v[-1]).max() < 1e-3


# -- bad input ------------------------------------------------------------------------------------------------
def _run(model, src):
    return dynamics.simulate(model, [0.3, 0.4], [0.0, 0.0], 0.01, torque=src)


@pytest.mark.parametrize("make, match", [
    (lambda: Target("tpi", [1.0, 0, 0.5], kp=1.0, kd=1.0), r"frame: no frame named 'tpi'.*'tip'"),
    (lambda: Target("tip", [1.0, 0.5], kp=1.0, kd=1.0), r"torque\.position: expected shape \(3,\)"),
    (lambda: OperationalSpace("tip", ([0.0, 1.0], np.zeros((3, 3))), 1.0, 1.0),
     r"torque\.reference\.position: expected shape \(2, 3\)"),
    (lambda: OperationalSpace("tip", ([1.0, 0.0], np.zeros((2, 3))), 1.0, 1.0),
     r"torque\.reference\.t: times must be strictly increasing"),
    (lambda: OperationalSpace("tip", "circle", 1.0, 1.0), r"torque\.reference: expected \(t, position\)"),
    (lambda: Target("tip", [1.0, 0, 0.5], kp=-1.0, kd=1.0), r"torque\.kp: expected values >= 0"),
    (lambda: Target("tip", [1.0, 0, 0.5], kp=1.0, kd=[1.0, 2.0], rows=[0, 1, 2]),
     r"torque\.kd: expected shape \(3,\)"),
    (lambda: Target("tip", [1.0, 0, 0.5], kp=1.0, kd=1.0, posture_kp=1.0), r"torque\.posture: required"),
    (lambda: Target("tip", [1.0, 0, 0.5], kp=1.0, kd=1.0, posture_kd=-2.0), r"torque\.posture_kd"),
    (lambda: Target("tip", [1.0, 0, 0.5], kp=1.0, kd=1.0, rows=[0, 5]), r"torque\.rows: the angular rows"),
    (lambda: Target("tip", [1.0, 0, 0.5], kp=1.0, kd=1.0, rows=[0, 7]), r"rows: expected distinct indices"),
    (lambda: Target("tip", [1.0, 0, 0.5], 2 * np.eye(3), kp=1.0, kd=1.0), r"torque\.orientation: expected rot"),
    (lambda: Target("tip", [1.0, 0, 0.5], kp=1.0, kd=1.0, damping=-1.0), r"torque\.damping"),
])
def test_bad_input_names_the_argument(arm2, make, match):
    with pytest.raises(dynamics.InputError, match=match):
        _run(arm2, make())


def test_floating_base_is_refused():
    box = dynamics.load_urdf("""<robot name="box"><link name="box"><inertial><mass value="2"/>
        <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/></inertial></link></robot>""",
                             floating_base=True)
    q0 = np.array([0, 0, 0, 0, 0, 0, 1.0])
    with pytest.raises(dynamics.InputError, match="fixed-base"):
        dynamics.simulate(box, q0, np.zeros(6), 0.01, torque=Target("box", [0, 0, 1.0], kp=1.0, kd=1.0))


def test_singular_task_stops_the_run_honestly(arm2):
    """The planar arm with all three position rows (the row normal to its plane is zero): J M^-1 J^T has rank 2,
    the torque is NaN and the run says it is unstable rather than returning a wrong answer; damping makes it
    finite."""
    tr = dynamics.simulate(arm2, [0.3, 0.4], [0.0, 0.0], 0.1, torque=Target("tip", [1.0, 0.0, 0.5], kp=1.0, kd=1.0))
    assert tr.report["status"].startswith("unstable")
    tr = dynamics.simulate(arm2, [0.3, 0.4], [0.0, 0.0], 0.1,
                           torque=Target("tip", [1.0, 0.0, 0.5], kp=1.0, kd=1.0, damping=1e-3))
    assert tr.report["status"] == "ok" and np.all(np.isfinite(tr.q))
