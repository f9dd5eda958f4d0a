"""integrator="implicit_euler": symplectic Euler with the stiff forces (contact, the passive torques, a PD source)
linearly implicit (core/simulation/implicit_euler.cpp), against independent references: symplectic Euler where
nothing is stiff, a tight adaptive run for its first order, and the weight a standing robot puts on the ground."""

import os
import warnings

import numpy as np
import pytest

import dynamics
from robots import OUR_ROBOTS, erd

G = 9.81

TWO_LINKS = """<robot name="two"><link name="base"/>
  <link name="a"><inertial><origin xyz="0 0 -0.25"/><mass value="1.0"/>
    <inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="b"><inertial><origin xyz="0 0 -0.2"/><mass value="0.5"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="continuous"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/></joint>
  <joint name="j2" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0 0 -0.5"/>
    <axis xyz="0 1 0"/></joint></robot>"""


@pytest.fixture(scope="module")
def panda():
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")
    q0 = np.array([0.1, -0.4, 0.2, -2.0, 0.1, 1.6, 0.7, 0.02, 0.02])
    return model, q0


@pytest.fixture(scope="module")
def go1():
    from benchmarks.contact import ours_contact, ours_initial, ours_model, ours_torque, quadruped_scene
    scene = quadruped_scene()
    model, contact = ours_model(scene), ours_contact(scene)
    q0, v0 = ours_initial(scene, model)
    return scene, model, contact, q0, v0, ours_torque(scene, model, q0)


def test_without_stiff_forces_it_is_symplectic_euler():
    """No damping, no limits, no PD, no contact: M dv = h (tau - C v - g) by the RNEA and the tree factorisation is
    symplectic Euler's step with the ABA's accelerations, to rounding."""
    model = dynamics.load_urdf(TWO_LINKS)
    q0, v0 = np.array([0.7, -0.4]), np.array([0.5, 1.0])
    a = dynamics.simulate(model, q0, v0, 1.0, integrator="euler", dt=1e-3)
    b = dynamics.simulate(model, q0, v0, 1.0, integrator="implicit_euler", dt=1e-3)
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-11)
    np.testing.assert_allclose(b.v, a.v, rtol=0, atol=1e-10)
    assert b.report["jacobian_evals"] == b.report["rhs_evals"] == 1000  # one evaluation and one solve a step


def test_first_order_against_a_tight_run(panda):
    model, q0 = panda
    pd = dynamics.torques.PD(kp=50.0, kd=5.0, q_target=q0 + 0.2)
    ref = dynamics.simulate(model, q0, np.zeros(9), 0.5, torque=pd, rtol=1e-10, atol=1e-12).q[-1]
    errs = [np.abs(dynamics.simulate(model, q0, np.zeros(9), 0.5, torque=pd, integrator="implicit_euler",
                                     dt=dt, error_estimate="none").q[-1] - ref).max() for dt in (2e-3, 1e-3, 5e-4)]
    assert 1e-4 < errs[0] < 2e-2
    for coarse, fine in zip(errs, errs[1:]):
        assert 1.8 < coarse / fine < 2.2  # order 1


def test_a_stiff_pd_is_stable_where_euler_blows_up(panda):
    model, q0 = panda
    target = q0 + 0.2
    pd = dynamics.torques.PD(kp=5e5, kd=5e3, q_target=target)
    with pytest.warns(dynamics.SimulationWarning, match="stability limit"):
        explicit = dynamics.simulate(model, q0, np.zeros(9), 0.3, torque=pd, integrator="euler", dt=2e-3)
    assert explicit.report["status"] != "ok"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no stability warning: the PD is in the implicit part
        traj = dynamics.simulate(model, q0, np.zeros(9), 0.3, torque=pd, integrator="implicit_euler", dt=2e-3)
    assert traj.report["status"] == "ok"
    # at rest at the target, less the sag gravity gives a spring of kp
    g = dynamics.gravity_torques(model, traj.q[-1])
    np.testing.assert_allclose(traj.q[-1], target - g / 5e5, atol=1e-6)


def test_go1_stands_on_its_feet_at_a_2ms_step(go1):
    """MuJoCo's step on the contact benchmark's quadruped: one evaluation and one solve per 2 ms, about as accurate
    as explicit Euler at four evaluations (0.5 ms substeps), which is unstable at 2 ms."""
    scene, model, contact, q0, v0, torque = go1
    Q0 = np.repeat(q0[None], 3, axis=0)
    Q0[1:, 7:] += np.random.default_rng(1).uniform(-0.02, 0.02, (2, model.nq - 7))
    kw = dict(dt=2e-3, torque=torque, contact=contact)
    sim = dynamics.Simulator(model, Q0, v0, integrator="implicit_euler", **kw)
    euler = dynamics.Simulator(model, Q0, v0, integrator="euler", substep=5e-4, **kw)
    ref = dynamics.Simulator(model, Q0, v0, rtol=1e-8, atol=1e-10, **kw)
    for _ in range(150):
        sim.step(), euler.step(), ref.step()
    assert not sim.failed.any()
    assert sim.stats["rhs_evals"] == 150 * 3 and euler.stats["rhs_evals"] == 4 * 150 * 3
    weight = scene.mass * G
    for i in range(3):
        fn = sim.contact_forces(i, details=True)[1].normal_force.sum()
        fn_ref = ref.contact_forces(i, details=True)[1].normal_force.sum()
        assert fn / weight == pytest.approx(1.0, abs=0.05)  # at rest: the feet carry the weight
        assert abs(fn - fn_ref) / weight < 0.1
    err_q, err_v = dynamics.simulation.state_error(model, sim.q, sim.v, ref.q, ref.v)
    euler_q, euler_v = dynamics.simulation.state_error(model, euler.q, euler.v, ref.q, ref.v)
    assert err_q < 2 * euler_q < 0.05 and err_v < 2 * euler_v
    alone = dynamics.Simulator(model, Q0[2], v0, integrator="implicit_euler", **kw)
    for _ in range(150):
        alone.step()
    assert np.array_equal(alone.q, sim.q[2]) and np.array_equal(alone.v, sim.v[2])  # a batch gives the bits alone


def test_a_ball_on_a_ball_couples_two_trees():
    """A free ball resting on a floating ball: the contact between two roots lies on no single path to the root,
    so the step factors densely; both come to rest, the lower one carrying both weights."""
    R, m = 0.05, 0.2
    ball = dynamics.load_urdf(f"""<robot name="ball"><link name="ball"><inertial><mass value="{m}"/>
      <inertia ixx="2e-4" iyy="2e-4" izz="2e-4" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>""",
                              floating_base=True)
    model = dynamics.add_free_body(ball, "top", dynamics.Sphere("top", R), m)
    contact = dynamics.Contact(geometries=[dynamics.Sphere("ball", R), dynamics.Sphere("top", R)])
    q0 = np.r_[0, 0, R, 0, 0, 0, 1, 0, 0, 3 * R + 0.01, 0, 0, 0, 1]
    traj = dynamics.simulate(model, q0, np.zeros(12), 1.5, contact=contact, integrator="implicit_euler", dt=2e-3)
    assert traj.report["status"] == "ok"
    assert traj.q[-1, 2] == pytest.approx(R, abs=2e-3)
    assert traj.q[-1, 9] == pytest.approx(3 * R, abs=4e-3)
    np.testing.assert_allclose(traj.v[-1], 0.0, atol=2e-2)


def test_closed_loops_step_as_symplectic_euler():
    """The loops' forces are not in the implicit part: a four-bar steps as symplectic Euler does."""
    model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "four_bar.urdf"))
    q0 = dynamics.assemble(model, np.array([0.2, 0.5, 1.5]), fixed=["theta1"])
    v0 = dynamics.project_velocity(model, q0, np.array([4.0, 0, 0]))
    a = dynamics.simulate(model, q0, v0, 0.2, integrator="euler", dt=1e-3)
    b = dynamics.simulate(model, q0, v0, 0.2, integrator="implicit_euler", dt=1e-3)
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-12)


def test_the_names_reach_every_door(panda):
    model, q0 = panda
    with pytest.raises(dynamics.InputError, match="dt"):
        dynamics.simulate(model, q0, np.zeros(9), 0.1, integrator="implicit_euler")
    with pytest.raises(dynamics.InputError, match="implicit_euler"):
        dynamics.simulate(model, q0, np.zeros(9), 0.1, integrator="implicit_euler", dt=1e-3,
                          sensitivities=True)
    sim = dynamics.Simulator(model, q0, np.zeros(9), dt=1e-3, integrator="implicit_euler", error_estimate="rerun")
    sim.step()
    assert 0 < sim.error < 1e-3
