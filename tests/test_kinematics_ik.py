"""Inverse kinematics on Panda and UR5 (issue 9, section 4), and bad input to every kinematics function."""

import numpy as np
import pytest

import dynamics
from robots import erd, random_state

ARMS = {"panda": ("panda_description/urdf/panda.urdf", "panda_hand"), "ur5": ("ur_description/urdf/ur5_robot.urdf",
                                                                              "tool0")}


def arm(name):
    rel, frame = ARMS[name]
    return dynamics.load_urdf(erd(rel)), frame


def within_limits(model, Q):
    return np.all((Q >= model.lower - 1e-12) & (Q <= model.upper + 1e-12))


@pytest.mark.parametrize("name", ARMS)
def test_reachable_poses_converge(name):
    """Targets are placements of random configurations within the limits, away from singularities (near one,
    e.g. UR5's wrist at q5 = 0, the damped steps converge too, but slowly); the solver starts 0.3 rad away."""
    model, frame = arm(name)
    rng = np.random.default_rng(0)
    lo, hi = np.maximum(model.lower, -np.pi), np.minimum(model.upper, np.pi)
    Qt = rng.uniform(lo, hi, (60, model.nq))
    Qt = Qt[np.linalg.svd(dynamics.frame_jacobian(model, Qt, frame), compute_uv=False)[:, 5] > 1e-2][:40]
    T = dynamics.frame_placement(model, Qt, frame)
    Q0 = np.clip(Qt + rng.uniform(-0.3, 0.3, Qt.shape), lo, hi)
    Q, rep = dynamics.inverse_kinematics(model, frame, T, Q0, respect_limits=True)
    assert Q.shape == Q0.shape and rep["converged"].shape == (40,)
    assert rep["converged"].all(), rep["status"]
    assert (rep["residual"] < 1e-10).all() and (rep["iterations"] <= 100).all()
    assert within_limits(model, Q)
    reached = dynamics.frame_placement(model, Q, frame)
    assert np.abs(reached - T).max() < 1e-9
    # the report is honest: its errors are those of the returned q
    q, r = dynamics.inverse_kinematics(model, frame, T[3], Q0[3])
    assert r["converged"] is True and r["status"] == "converged" and isinstance(r["iterations"], int)
    Tq = dynamics.frame_placement(model, q, frame)
    assert abs(np.linalg.norm(Tq[:3, 3] - T[3][:3, 3]) - r["position_error"]) < 1e-12


@pytest.mark.parametrize("name", ARMS)
def test_position_only_from_the_neutral_pose(name):
    model, frame = arm(name)
    rng = np.random.default_rng(1)
    lo, hi = np.maximum(model.lower, -np.pi), np.minimum(model.upper, np.pi)
    P = dynamics.frame_placement(model, rng.uniform(lo, hi, (10, model.nq)), frame)[:, :3, 3]
    Q, rep = dynamics.inverse_kinematics(model, frame, P, np.clip(model.neutral(), lo, hi), position_only=True)
    assert rep["converged"].all(), rep["status"]
    np.testing.assert_allclose(dynamics.frame_placement(model, Q, frame)[:, :3, 3], P, atol=1e-10)


@pytest.mark.parametrize("name", ARMS)
def test_unreachable_targets_are_reported_not_raised(name):
    model, frame = arm(name)
    target = np.eye(4)
    target[:3, 3] = [3.0, 0.0, 0.5]  # 3 m away: beyond either arm's reach
    q, rep = dynamics.inverse_kinematics(model, frame, target, model.neutral())
    assert rep["converged"] is False and rep["status"] in ("stalled", "max_iter")
    assert rep["position_error"] > 1.0 and np.all(np.isfinite(q))
    # the reported error is that of the returned configuration
    Tq = dynamics.frame_placement(model, q, frame)
    assert abs(np.linalg.norm(Tq[:3, 3] - target[:3, 3]) - rep["position_error"]) < 1e-9
    # a pose the arm reaches with its position but not with that orientation under tight limits
    q, rep = dynamics.inverse_kinematics(model, frame, target, model.neutral(), max_iter=3)
    assert rep["converged"] is False and rep["iterations"] <= 3


def test_floating_base_ik_keeps_a_unit_quaternion():
    model = dynamics.load_urdf(erd("talos_data/robots/talos_full_v2.urdf"), floating_base=True)
    rng = np.random.default_rng(2)
    q0 = model.neutral()
    qt = random_state(model, rng)[0]
    T = dynamics.frame_placement(model, qt, "left_sole_link")
    q, rep = dynamics.inverse_kinematics(model, "left_sole_link", T, q0)
    assert rep["converged"], rep
    assert abs(np.linalg.norm(q[3:7]) - 1) < 1e-12
    assert np.abs(dynamics.frame_placement(model, q, "left_sole_link") - T).max() < 1e-9


# -- bad input ---------------------------------------------------------------------------------------------

def test_unknown_frames_list_the_closest_names():
    model, _ = arm("panda")
    q = model.neutral()
    with pytest.raises(dynamics.InputError, match=r"frame: no frame named 'panda_hnd'.*closest: \['panda_hand'"):
        dynamics.frame_jacobian(model, q, "panda_hnd")
    with pytest.raises(dynamics.InputError, match="frame: no frame named"):
        model.frame_index("nothing_like_it")
    with pytest.raises(dynamics.InputError, match=r"frame: index 99 out of range"):
        dynamics.frame_placement(model, q, 99)
    with pytest.raises(dynamics.InputError, match="frame: expected a frame name"):
        dynamics.frame_velocity(model, q, np.zeros(model.nv), 1.5)
    for fn in (lambda: dynamics.frame_placement(model, q, "x"), lambda: dynamics.center_of_mass(model, q[:3]),
               lambda: dynamics.inverse_kinematics(model, "panda_hnd", np.eye(4), q)):
        with pytest.raises(dynamics.InputError):
            fn()


def test_bad_references_points_rows_targets_and_damping():
    model, frame = arm("panda")
    q = model.neutral()
    with pytest.raises(dynamics.InputError, match=r"reference: expected one of \['world', 'local', "
                                                  r"'local_world_aligned'\], got 'LOCAL'"):
        dynamics.frame_jacobian(model, q, frame, reference="LOCAL")
    with pytest.raises(dynamics.InputError, match="reference"):
        dynamics.frame_acceleration(model, q, q[:9], q[:9], frame, reference=None)
    with pytest.raises(dynamics.InputError, match=r"point: expected shape \(3,\)"):
        dynamics.frame_jacobian(model, q, frame, point=[1, 2])
    with pytest.raises(dynamics.InputError, match="point: contains non-finite"):
        dynamics.frame_jacobian(model, q, frame, point=[1, 2, np.nan])
    for rows in ([0, 0], [6], [], "xyz", [0.5]):
        with pytest.raises(dynamics.InputError, match="rows"):
            dynamics.operational_space_inertia(model, q, frame, rows=rows)
    with pytest.raises(dynamics.InputError, match="damping"):
        dynamics.operational_space_inertia(model, q, frame, damping=-1)
    with pytest.raises(dynamics.InputError, match="target: the rotation part is not a rotation"):
        dynamics.inverse_kinematics(model, frame, 2 * np.eye(4), q)
    with pytest.raises(dynamics.InputError, match=r"target: expected shape \(4, 4\)"):
        dynamics.inverse_kinematics(model, frame, [0.3, 0.2, 0.4], q)  # a position needs position_only
    with pytest.raises(dynamics.InputError, match="max_iter"):
        dynamics.inverse_kinematics(model, frame, np.eye(4), q, max_iter=-1)
    with pytest.raises(dynamics.InputError, match="q0: expected shape"):
        dynamics.inverse_kinematics(model, frame, np.eye(4), q[:4])


def test_singular_mass_matrix_names_the_joint():
    urdf = """<robot name="r"><link name="base"/><link name="a"/><link name="b"><inertial><mass value="1"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
    <joint name="j1" type="prismatic"><parent link="base"/><child link="a"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    <origin xyz="0 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    <link name="c"/><joint name="j3" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""
    model = dynamics.load_urdf(urdf)
    with pytest.raises(dynamics.InputError, match="singular at joint 'j3'"):
        dynamics.inverse_mass_matrix(model, np.zeros(model.nv))
    with pytest.raises(dynamics.InputError, match="singular at joint 'j3'"):
        dynamics.operational_space_inertia(model, np.zeros(model.nv), "b")
