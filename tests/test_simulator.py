"""``dynamics.Simulator``: a simulation stepped from the caller's loop.

References: ``simulate`` itself (a fixed-step method stepped period by period gives the bits of one run sampled at
the periods; a torque held by step() is a constant torque source), a tight adaptive run (the stepped adaptive
methods agree within their tolerance), closed forms (a ball resting on the ground carries its weight; a free
pendulum keeps its energy), and the identity "a batch gives each environment the bits it has alone".
"""

import os
import warnings

import numpy as np
import pytest

import dynamics
from robots import OUR_ROBOTS, erd

G = 9.81


@pytest.fixture(scope="module")
def panda():
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")
    q0 = np.array([0.1, -0.4, 0.2, -2.0, 0.1, 1.6, 0.7, 0.02, 0.02])
    pd = dynamics.torques.PD(kp=50.0, kd=5.0, q_target=q0 + 0.2)
    return model, q0, pd


def test_rk4_stepped_is_simulate_bit_for_bit(panda):
    model, q0, pd = panda
    v0 = np.linspace(-0.3, 0.3, model.nv)
    dt, K = 2e-4, 60
    tr = dynamics.simulate(model, q0, v0, K * dt, torque=pd, integrator="rk4", dt=dt, error_estimate="none")
    sim = dynamics.Simulator(model, q0, v0, dt=dt, torque=pd, integrator="rk4")
    for k in range(K):
        sim.step()
        assert sim.t == tr.t[k + 1]
        np.testing.assert_array_equal(sim.q, tr.q[k + 1])
        np.testing.assert_array_equal(sim.v, tr.v[k + 1])
    assert sim.stats["steps"] == K and np.isnan(sim.error)


def test_held_torque_is_a_constant_torque_source(panda):
    model, q0, _ = panda
    tau = np.linspace(-2.0, 2.0, model.nv)
    dt, K = 2e-4, 40
    tr = dynamics.simulate(model, q0, np.zeros(model.nv), K * dt, torque=tau, integrator="rk4", dt=dt,
                           error_estimate="none")
    sim = dynamics.Simulator(model, q0, np.zeros(model.nv), dt=dt, integrator="rk4")
    for _ in range(K):
        sim.step(tau)
    np.testing.assert_array_equal(sim.q, tr.q[-1])
    np.testing.assert_array_equal(sim.v, tr.v[-1])
    # the held torque's work over the last period: the power v . tau integrated (the source's quadrature)
    assert sim.work[0] == pytest.approx(float(np.mean([tr.v[-2] @ tau, tr.v[-1] @ tau])) * dt, rel=1e-3)


def test_substeps_split_the_period(panda):
    model, q0, pd = panda
    v0 = np.zeros(model.nv)
    tr = dynamics.simulate(model, q0, v0, 0.01, torque=pd, integrator="rk4", dt=2.5e-4, error_estimate="none")
    sim = dynamics.Simulator(model, q0, v0, dt=1e-3, substep=2.5e-4, torque=pd, integrator="rk4")
    for _ in range(10):
        sim.step()
    assert sim.stats["steps"] == 40
    np.testing.assert_allclose(sim.q, tr.q[-1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(sim.v, tr.v[-1], rtol=0, atol=1e-10)


@pytest.mark.parametrize("integrator", ["auto", "rk45", "dop853", "radau"])
def test_adaptive_stepping_agrees_with_a_tight_run(panda, integrator):
    model, q0, pd = panda
    v0 = np.linspace(0.2, -0.2, model.nv)
    ref = dynamics.simulate(model, q0, v0, 0.05, torque=pd, integrator="dop853", rtol=1e-12, atol=1e-12,
                            error_estimate="none")
    sim = dynamics.Simulator(model, q0, v0, dt=5e-3, torque=pd, integrator=integrator, rtol=1e-8, atol=1e-10)
    estimates = []
    for _ in range(10):
        sim.step()
        estimates.append(sim.error)
    assert sim.t == pytest.approx(0.05, abs=1e-15)
    err = max(dynamics.simulation.state_error(model, sim.q, sim.v, ref.q[-1], ref.v[-1]))
    # the periods' estimates (their local errors summed) bound the error, and stay near the tolerance asked for
    assert err <= sum(estimates) < 1e-5


def test_a_batch_gives_each_environment_its_bits_alone(panda):
    model, q0, pd = panda
    rng = np.random.default_rng(3)
    Q0 = q0 + 0.1 * rng.standard_normal((5, model.nq))
    V0 = 0.2 * rng.standard_normal((5, model.nv))
    TAU = rng.standard_normal((5, model.nv))
    batch = dynamics.Simulator(model, Q0, V0, dt=1e-3, torque=pd, rtol=1e-8)
    for _ in range(5):
        batch.step(TAU)
    assert batch.q.shape == (5, model.nq) and batch.t.shape == (5,)
    for i in range(5):
        one = dynamics.Simulator(model, Q0[i], V0[i], dt=1e-3, torque=pd, rtol=1e-8)
        for _ in range(5):
            one.step(TAU[i])
        np.testing.assert_array_equal(batch.q[i], one.q)
        np.testing.assert_array_equal(batch.v[i], one.v)
        assert batch.error[i] == one.error


def test_threads_do_not_change_the_bits(panda, monkeypatch):
    model, q0, pd = panda
    Q0 = q0 + 0.05 * np.arange(8)[:, None]
    out = []
    for threads in (1, 2):
        monkeypatch.setattr(dynamics.simulation.simulator, "num_threads", lambda: threads)
        sim = dynamics.Simulator(model, Q0, np.zeros(model.nv), dt=2e-3, torque=pd)
        for _ in range(3):
            sim.step()
        out.append(sim.q.copy())
    np.testing.assert_array_equal(out[0], out[1])


@pytest.mark.parametrize("integrator", ["rk4", "auto"])
def test_state_and_set_state_roll_back(panda, integrator):
    model, q0, pd = panda
    sim = dynamics.Simulator(model, q0, np.zeros(model.nv), dt=2e-3, torque=pd, integrator=integrator)
    for _ in range(4):
        sim.step(np.ones(model.nv))
    x = sim.state()
    assert x.shape == (1 + model.nq + model.nv + 4,)
    for _ in range(3):
        sim.step(-np.ones(model.nv))
    first = sim.state()
    branches = []
    for _ in range(2):
        sim.set_state(x)
        assert sim.t == x[0]
        for _ in range(3):
            sim.step(-np.ones(model.nv))
        branches.append(sim.state())
    np.testing.assert_array_equal(branches[0], branches[1])  # a branch is a function of its state and torques
    if integrator == "rk4":  # a fixed-step method keeps nothing else: the same bits as the first continuation
        np.testing.assert_array_equal(branches[0], first)
    else:  # an adaptive one starts its Newton matrix and controller afresh: the same within its tolerance
        np.testing.assert_allclose(branches[0][:-4], first[:-4], rtol=0, atol=1e-7)


def test_reset(panda):
    model, q0, pd = panda
    sim = dynamics.Simulator(model, np.stack([q0, q0]), np.zeros(model.nv), dt=1e-3, torque=pd)
    sim.step()
    moved = sim.q.copy()
    sim.reset(which=[1])
    np.testing.assert_array_equal(sim.q[1], q0)
    np.testing.assert_array_equal(sim.q[0], moved[0])
    assert list(sim.t) == [1e-3, 0.0]
    sim.reset(q0 + 0.1, np.ones(model.nv), which=np.array([True, False]), t=5.0)
    np.testing.assert_array_equal(sim.q[0], q0 + 0.1)
    assert sim.t[0] == 5.0
    sim.step()
    assert sim.t[0] == pytest.approx(5.001, abs=1e-12)


def test_views_are_read_only_and_live(panda):
    model, q0, pd = panda
    sim = dynamics.Simulator(model, q0, np.zeros(model.nv), dt=1e-3, torque=pd)
    q = sim.q
    with pytest.raises(ValueError):
        q[0] = 1.0
    sim.step()
    np.testing.assert_array_equal(q, sim.q)  # the same memory: no copy per step
    assert not np.array_equal(q, q0)


def test_a_failed_environment_is_marked_and_the_others_go_on():
    model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "double_pendulum.urdf")) if os.path.exists(
        os.path.join(OUR_ROBOTS, "double_pendulum.urdf")) else None
    if model is None:
        from robots import chain_urdf
        model = dynamics.load_urdf(chain_urdf(2))
    Q0 = np.zeros((3, model.nq))
    V0 = np.zeros((3, model.nv))
    V0[1] = 1e3  # above the blow-up bound after a stiff PD kick
    sim = dynamics.Simulator(model, Q0, V0, dt=1e-2, integrator="euler")
    TAU = np.zeros((3, model.nv))
    TAU[1] = 1e12
    with pytest.warns(dynamics.SimulationWarning, match="environment 1: the period from t=0 s failed"):
        sim.step(TAU)
    assert list(sim.failed) == [False, True, False]
    assert "velocity exceeded" in sim.status[1]
    np.testing.assert_array_equal(sim.q[1], Q0[1])  # left at the period's start
    assert sim.t[1] == 0.0 and sim.t[0] == pytest.approx(1e-2)
    sim.step()  # the failed one waits, the others go on
    assert sim.t[1] == 0.0 and sim.t[0] == pytest.approx(2e-2)
    sim.reset(which=[1])
    sim.step()
    assert not sim.failed.any() and sim.t[1] == pytest.approx(1e-2)


def test_a_single_simulation_refuses_to_step_after_a_failure():
    from robots import chain_urdf
    model = dynamics.load_urdf(chain_urdf(2))
    sim = dynamics.Simulator(model, np.zeros(2), np.zeros(2), dt=1e-2, integrator="euler")
    with pytest.warns(dynamics.SimulationWarning, match="failed"):
        sim.step([1e12, 0.0])
    assert sim.failed and sim.t == 0.0
    with pytest.raises(dynamics.InputError, match="reset"):
        sim.step()
    x = sim.state()
    sim.set_state(x)
    sim.step()
    assert sim.t == pytest.approx(1e-2)


def test_a_torque_callable_that_raises():
    from robots import chain_urdf
    model = dynamics.load_urdf(chain_urdf(2))
    calls = []

    def torque(t, q, v):
        calls.append(t)
        if t > 0.015:
            raise RuntimeError("policy crashed")
        return np.zeros(2)

    sim = dynamics.Simulator(model, np.zeros(2), np.zeros(2), dt=1e-2, integrator="rk4", torque=torque)
    sim.step()
    with pytest.raises(RuntimeError, match="policy crashed"):
        sim.step()
    assert sim.failed and sim.t == pytest.approx(1e-2)
    sim.reset()
    sim.step()
    assert sim.t == pytest.approx(1e-2) and calls


def test_a_pendulum_keeps_its_energy():
    from robots import chain_urdf
    model = dynamics.load_urdf(chain_urdf(1, damping=0.0))
    sim = dynamics.Simulator(model, [1.0], [0.0], dt=1e-2, integrator="dop853", rtol=1e-10, atol=1e-12)
    sim.step()
    E0 = sim.energy.sum()
    for _ in range(200):
        sim.step()
    assert abs(sim.energy.sum() - E0) < 1e-7 * abs(E0) + 1e-9
    assert np.all(sim.work == pytest.approx(0.0, abs=1e-12))  # no torque, no damping: nothing does work


def test_a_ball_comes_to_rest_on_the_ground():
    R, m = 0.05, 0.2
    ball = dynamics.load_urdf(f"""<robot name="ball"><link name="ball"><inertial><mass value="{m}"/>
      <inertia ixx="2e-4" iyy="2e-4" izz="2e-4" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>""",
                              floating_base=True)
    contact = dynamics.Contact(geometries=[dynamics.Sphere("ball", R)])
    sim = dynamics.Simulator(ball, [0, 0, 0.2, 0, 0, 0, 1], np.zeros(6), dt=1e-2, contact=contact,
                             error_estimate="rerun")
    for _ in range(150):
        sim.step()
        assert sim.error < 1e-3  # the rerun on its own contact model
    assert sim.q[2] == pytest.approx(R, abs=2e-3)  # resting, pressed in by its weight
    f = sim.contact_forces()
    assert f[0, 2] == pytest.approx(m * G, rel=1e-2)  # the ground carries the weight (body frame = world here)
    assert sim.work.shape == (3,)
    two = dynamics.Simulator(ball, [[0, 0, 0.2, 0, 0, 0, 1], [0, 0, 0.1, 0, 0, 0, 1]], np.zeros(6), dt=1e-2,
                             contact=contact)
    for _ in range(150):
        two.step()
    np.testing.assert_allclose(two.q[:, 2], R, atol=2e-3)
    assert two.contact_forces(1)[0, 2] == pytest.approx(m * G, rel=1e-2)
    with pytest.raises(dynamics.InputError, match="env"):
        two.contact_forces()
    with pytest.raises(dynamics.InputError, match="no contact"):
        dynamics.Simulator(ball, [0, 0, 0.2, 0, 0, 0, 1], np.zeros(6), dt=1e-2).contact_forces()


def test_a_closed_loop_steps_like_simulate():
    model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "four_bar.urdf"))
    q0 = dynamics.assemble(model, np.array([0.2, 0.5, 1.5]), fixed=["theta1"])
    v0 = dynamics.project_velocity(model, q0, np.array([4.0, 0, 0]))
    tr = dynamics.simulate(model, q0, v0, 0.2, integrator="rk4", dt=1e-3, error_estimate="none")
    sim = dynamics.Simulator(model, q0, v0, dt=1e-3, integrator="rk4")
    for _ in range(200):
        sim.step()
    np.testing.assert_array_equal(sim.q, tr.q[-1])
    assert np.abs(dynamics.constraint_residual(model, sim.q)).max() < 1e-6


@pytest.mark.parametrize("bad, match", [
    (dict(tau=np.zeros(3)), r"tau: expected shape \(9,\)"),
    (dict(tau=np.full(9, np.nan)), "tau: velocity coordinate 0 .* expected finite"),
    (dict(tau="x"), "could not convert|tau"),
])
def test_bad_torques(panda, bad, match):
    model, q0, pd = panda
    sim = dynamics.Simulator(model, q0, np.zeros(model.nv), dt=1e-3, torque=pd)
    with pytest.raises((dynamics.InputError, ValueError), match=match):
        sim.step(**bad)
    assert sim.t == 0.0 and not sim.failed


def test_bad_arguments(panda):
    model, q0, pd = panda
    v0 = np.zeros(model.nv)
    for kw, match in [(dict(dt=0.0), "dt"), (dict(dt=np.nan), "dt"), (dict(dt=1e-3, integrator="rk5"), "integrator"),
                      (dict(dt=1e-3, integrator="rk4", substep=-1.0), "substep"),
                      (dict(dt=1.0, integrator="euler", substep=1e-9), "substep"),
                      (dict(dt=1e-3, rtol=0.0), "rtol")]:
        with pytest.raises(dynamics.InputError, match=match):
            dynamics.Simulator(model, q0, v0, **kw)
    with pytest.raises(dynamics.InputError, match=r"v0: expected shape \(9,\) or \(2, 9\)"):
        dynamics.Simulator(model, np.stack([q0, q0]), np.zeros((3, model.nv)), dt=1e-3)
    with pytest.raises(dynamics.InputError, match="q0"):
        dynamics.Simulator(model, q0[:3], v0, dt=1e-3)
    sim = dynamics.Simulator(model, np.stack([q0, q0]), v0, dt=1e-3)
    with pytest.raises(dynamics.InputError, match="which"):
        sim.reset(which=[2])
    with pytest.raises(dynamics.InputError, match="which"):
        sim.reset(which=np.array([True]))
    with pytest.raises(dynamics.InputError, match="x: expected shape"):
        sim.set_state(np.zeros(4))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.step(np.zeros((2, model.nv)))


def test_a_step_past_the_deadline(panda):
    import time
    model, q0, pd = panda
    sim = dynamics.Simulator(model, np.stack([q0, q0]), np.zeros(model.nv), dt=1e-3, torque=pd)
    with dynamics.parallel.deadline(time.monotonic() - 1.0):
        with pytest.raises(dynamics.DeadlineExceeded, match="deadline"):
            sim.step()
    assert list(sim.t) == [0.0, 0.0] and not sim.failed.any()  # left at the period's start, not marked
    sim.step()
    assert list(sim.t) == [1e-3, 1e-3]


def test_too_many_environments_for_the_memory_are_refused(panda, monkeypatch):
    model, q0, pd = panda
    monkeypatch.setattr(dynamics.simulation.simulator, "_available_memory", lambda: 2**20)  # 1 MiB available
    with pytest.raises(dynamics.InputError, match=r"100 environments would take about .* GiB .* available"):
        dynamics.Simulator(model, np.tile(q0, (100, 1)), np.zeros(model.nv), dt=1e-3, torque=pd, integrator="radau")


def test_threads_take_turns_on_one_simulator(panda):
    from concurrent.futures import ThreadPoolExecutor
    model, q0, pd = panda
    sim = dynamics.Simulator(model, np.tile(q0, (4, 1)), np.zeros(model.nv), dt=1e-3, torque=pd)
    with ThreadPoolExecutor(4) as ex:
        list(ex.map(lambda _: sim.step(), range(40)))
    np.testing.assert_allclose(sim.t, 0.04, rtol=0, atol=1e-12)  # every step counted once, none lost or torn


@pytest.mark.parametrize("integrator, substep", [("rk4", 2e-3), ("euler", 2e-4), ("auto", None), ("radau", None)])
def test_the_rerun_estimate_measures_each_periods_error(panda, integrator, substep):
    model, q0, pd = panda
    v0 = np.linspace(0.2, -0.2, model.nv)
    sim = dynamics.Simulator(model, q0, v0, dt=2e-3, substep=substep, torque=pd, integrator=integrator,
                             error_estimate="rerun")
    for _ in range(3):
        ref = dynamics.Simulator(model, sim.q.copy(), sim.v.copy(), dt=2e-3, torque=pd, integrator="dop853",
                                 rtol=1e-13, atol=1e-14)  # the same period, converged
        ref.step()
        sim.step()
        true = max(dynamics.simulation.state_error(model, sim.q, sim.v, ref.q, ref.v))
        assert 0.5 * true <= sim.error <= 2.0 * true + 1e-12


def test_error_estimate_arguments(panda):
    model, q0, pd = panda
    with pytest.raises(dynamics.InputError, match="'local' needs an adaptive integrator"):
        dynamics.Simulator(model, q0, np.zeros(model.nv), dt=1e-3, integrator="rk4", error_estimate="local")
    with pytest.raises(dynamics.InputError, match="error_estimate"):
        dynamics.Simulator(model, q0, np.zeros(model.nv), dt=1e-3, error_estimate="richardson")
    sim = dynamics.Simulator(model, q0, np.zeros(model.nv), dt=1e-3, integrator="rk4", error_estimate="none")
    sim.step()
    assert np.isnan(sim.error) and sim.error_estimate == "none"


def test_auto_stays_stiff_while_a_quadruped_stands():
    """A period caps radau's step, so h rho looks small while the feet's friction is as stiff as ever: auto must not
    hand a standing robot to rk45, which would crawl at the friction's stability limit (here ~90x the work)."""
    from benchmarks.contact import ours_contact, ours_initial, ours_model, ours_torque, quadruped_scene
    scene = quadruped_scene()
    model, contact = ours_model(scene), ours_contact(scene)
    q0, v0 = ours_initial(scene, model)
    torque = ours_torque(scene, model, q0)  # PD to the posture, released 0.02 rad away from it
    q0 = q0 + np.r_[np.zeros(7), np.random.default_rng(0).uniform(-0.02, 0.02, (91, model.nq - 7))[90]]
    kw = dict(dt=2e-3, torque=torque, contact=contact, rtol=1e-3, atol=1e-5)
    auto, radau = (dynamics.Simulator(model, q0, v0, integrator=i, **kw) for i in ("auto", "radau"))
    for _ in range(100):
        auto.step()
        radau.step()
    assert auto.stats["rhs_evals"] < 2 * radau.stats["rhs_evals"]
    assert max(dynamics.simulation.state_error(model, auto.q, auto.v, radau.q, radau.v)) < 1e-2


def test_a_reset_starts_a_new_episode_of_contact():
    """After reset, auto must see the first touch again (touchdown) and go stiff, as a fresh simulator does: the
    same right-hand sides, the same bits."""
    from benchmarks.contact import ours_contact, ours_initial, ours_model, ours_torque, quadruped_scene
    scene = quadruped_scene()
    model, contact = ours_model(scene), ours_contact(scene)
    q0, v0 = ours_initial(scene, model)
    kw = dict(dt=2e-3, torque=ours_torque(scene, model, q0), contact=contact, rtol=1e-3, atol=1e-5)
    sim = dynamics.Simulator(model, q0, v0, **kw)
    for _ in range(20):
        sim.step()
    first, rhs = sim.state(), sim.stats["rhs_evals"]
    sim.reset()
    for _ in range(20):
        sim.step()
    np.testing.assert_array_equal(sim.state(), first)
    assert sim.stats["rhs_evals"] == 2 * rhs


def test_torque_layouts_give_the_same_bits(panda):
    model, q0, pd = panda
    tau = np.linspace(-1, 1, 2 * model.nv).reshape(2, model.nv)
    out = []
    for t in (tau, np.asfortranarray(tau), tau.tolist(), np.repeat(tau, 2, axis=1)[:, ::2]):
        sim = dynamics.Simulator(model, np.stack([q0, q0]), np.zeros(model.nv), dt=1e-3, torque=pd)
        sim.step(t)
        out.append(sim.q.copy())
    for q in out[1:]:
        np.testing.assert_array_equal(q, out[0])
    one = dynamics.Simulator(model, np.stack([q0, q0]), np.zeros(model.nv), dt=1e-3, torque=pd)
    one.step(tau[0][::1])  # (nv,): every environment
    np.testing.assert_array_equal(one.q[0], one.q[1])
    np.testing.assert_array_equal(one.q[0], out[0][0])


def test_a_torque_callable_is_not_called_before_the_first_step(panda):
    model, q0, pd = panda
    calls = []

    def torque(t, q, v):
        calls.append(t)
        return np.zeros(model.nv)

    sim = dynamics.Simulator(model, np.tile(q0, (64, 1)), np.zeros(model.nv), dt=1e-3, torque=torque)
    assert calls == []  # (the memory check makes an environment but does not step it)
    sim.step()
    assert calls and 0.0 <= min(calls) and max(calls) <= 1e-3  # all within the first period


def test_interleaved_simulators_keep_their_own_workspaces(panda):
    """A problem borrows its workspaces from its thread's pool (core/simulation/workspace_pool.hpp) and gives them
    back when it goes: two live simulators on one thread, one made and dropped between their steps, and one stepped
    from another thread, each give the bits they give alone."""
    from concurrent.futures import ThreadPoolExecutor
    model, q0, pd = panda
    ur5 = dynamics.load_urdf(erd("ur_description/urdf/ur5_robot.urdf"))
    args = [(model, q0, np.linspace(-0.2, 0.2, model.nv), pd, "radau"),
            (ur5, ur5.neutral() + 0.3, np.zeros(ur5.nv), dynamics.torques.PD(ur5.neutral(), 80.0, 8.0), "rk4")]

    def make(m, q, v, tau, integrator):
        return dynamics.Simulator(m, q, v, dt=2e-3, torque=tau, integrator=integrator)

    alone = []
    for a in args:
        sim = make(*a)
        alone.append([(sim.step(), sim.q.copy(), sim.v.copy())[1:] for _ in range(4)])
    sims = [make(*a) for a in args]
    with ThreadPoolExecutor(1) as other:
        for k in range(4):
            for j, sim in enumerate(sims):
                if k == 2 and j == 1:
                    other.submit(sim.step).result()  # (its workspaces stay its own on another thread)
                else:
                    sim.step()
                np.testing.assert_array_equal(sim.q, alone[j][k][0])
                np.testing.assert_array_equal(sim.v, alone[j][k][1])
            dropped = make(*args[0])  # made, stepped and gone between the steps: its workspaces back in the pool
            dropped.step()
            del dropped
