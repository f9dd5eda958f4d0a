"""simulate_many and map_batches on every engine: each run equals simulate run alone (bit for bit), a failing
run does not sink the others, Ray retries a chunk whose worker died, progress is reported."""

import os

import numpy as np
import pytest

import dynamics
from dynamics import engines
from dynamics.torques import PD

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def arm():
    return dynamics.load_urdf(dynamics.robots.path("planar_2r"))


@pytest.fixture(scope="module")
def local_ray():
    """One local Ray (2 CPUs) for the whole module: it takes seconds to start."""
    engines.ray_init(num_cpus=2)
    yield
    ray.shutdown()


def runs(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, (n, 2)), [PD(rng.uniform(-0.5, 0.5, 2), 100.0 + 10 * k, 10.0) for k in range(n)]


@pytest.mark.parametrize("engine", ["threads", "processes", "ray"])
def test_each_run_equals_simulate_alone(arm, engine, request):
    if engine == "ray":
        request.getfixturevalue("local_ray")
    Q0, pds = runs(12)
    many = dynamics.simulate_many(arm, Q0, np.zeros(2), 0.5, torque=pds, engine=engine, progress=False,
                                  sample_dt=0.01)
    assert many.q.shape == (12, 51, 2) and many.t.shape == (51,) and many.ok.all()
    for k in range(12):
        one = dynamics.simulate(arm, Q0[k], np.zeros(2), 0.5, torque=pds[k], sample_dt=0.01)
        np.testing.assert_array_equal(many.q[k], one.q)
        np.testing.assert_array_equal(many.tau[k], one.tau)
        assert many.reports[k]["steps"] == one.report["steps"] and many.reports[k]["run"] == k


def test_a_failing_run_does_not_sink_the_others(arm):
    Q0, pds = runs(6)
    pds[2] = np.zeros(5)  # wrong shape: refused for this run only
    V0 = np.zeros((6, 2))
    V0[4] = 1e9  # blows up
    many = dynamics.simulate_many(arm, Q0, V0, 0.5, torque=pds, integrator="rk4", dt=1e-2, progress=False)
    assert many.reports[2]["status"].startswith("failed: torque") and many.counts[2] == 0
    assert np.isnan(many.q[2]).all()
    assert many.reports[4]["status"] != "ok"
    assert [k for k in range(6) if many.ok[k]] == [0, 1, 3, 5]
    one = dynamics.simulate(arm, Q0[5], V0[5], 0.5, torque=pds[5], integrator="rk4", dt=1e-2)
    np.testing.assert_array_equal(many.q[5], one.q)


def test_ray_retries_a_chunk_whose_worker_died(arm, local_ray, tmp_path):
    marker = str(tmp_path / "died-once")

    def dies_once(t, q, v):  # a local function: Ray pickles it by value
        if not os.path.exists(marker):
            open(marker, "w").close()
            os._exit(1)  # the worker process dies mid-chunk
        return -5.0 * v

    Q0, _ = runs(8)
    torques = [None] * 8
    torques[5] = dies_once
    many = dynamics.simulate_many(arm, Q0, np.zeros(2), 0.2, torque=torques, engine="ray", progress=False)
    assert os.path.exists(marker) and many.ok.all()
    ref = dynamics.simulate(arm, Q0[5], np.zeros(2), 0.2, torque=lambda t, q, v: -5.0 * v)
    np.testing.assert_array_equal(many.q[5], ref.q)


def test_progress_callback(arm):
    seen = []
    Q0, pds = runs(9)
    dynamics.simulate_many(arm, Q0, np.zeros(2), 0.1, torque=pds, progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1] == (8, 8) and all(t == 8 for _, t in seen)  # the first run compiles in the caller


@pytest.mark.parametrize("engine", ["threads", "processes", "ray"])
def test_map_batches_equals_one_call(engine, request):
    if engine == "ray":
        request.getfixturevalue("local_ray")
    model = dynamics.load_urdf(dynamics.robots.path("puma560"))
    rng = np.random.default_rng(1)
    Q, V, A = rng.uniform(-1, 1, (3, 30_000, model.nq))
    tau = dynamics.map_batches(dynamics.inverse_dynamics, model, Q, V, A, engine=engine, chunk=7_000)
    np.testing.assert_array_equal(tau, dynamics.inverse_dynamics(model, Q, V, A))
    M = dynamics.map_batches(dynamics.mass_matrix, model, Q[:3000], engine=engine, chunk=1000)
    np.testing.assert_array_equal(M, dynamics.mass_matrix(model, Q[:3000]))


def test_missing_ray_says_how_to_install(arm, monkeypatch):
    real = engines.importlib.import_module

    def no_ray(name, *args):
        if name == "ray":
            raise ImportError("No module named 'ray'")
        return real(name, *args)

    monkeypatch.setattr(engines.importlib, "import_module", no_ray)
    monkeypatch.setattr(engines, "ray_init", lambda *a, **k: engines.ray_module())
    with pytest.raises(dynamics.InputError, match=r"pip install 'dynamics\[ray\]'"):
        dynamics.simulate_many(arm, np.zeros((3, 2)), np.zeros(2), 0.1, engine="ray", progress=False)


def test_bad_engine_and_shapes(arm):
    with pytest.raises(dynamics.InputError, match="engine: expected one of"):
        dynamics.simulate_many(arm, np.zeros((2, 2)), np.zeros(2), 0.1, engine="gpu")
    with pytest.raises(dynamics.InputError, match=r"v0: expected shape \(2,\) or \(3, 2\)"):
        dynamics.simulate_many(arm, np.zeros((3, 2)), np.zeros((2, 2)), 0.1)
