"""The torque sources' derivatives in the core (bindings/control.cpp: _core.torque_source_derivatives,
closed_loop_derivatives, rotation_log) called directly with what no public function passes: wrong shapes, float32,
non-contiguous or read-only arrays, NaN, a zero quaternion, a source or passive torques made for another model, a
callable that raises or returns the wrong shape.  A clear error (ValueError or TypeError, or the callable's own
exception), never a crash or a read or write out of bounds (the sanitizer stage can run this file); and well-made
calls agree with the public functions."""

import os

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.control.registry import release_callable
from dynamics.control.validation import make_source
from dynamics.errors import InputError
from dynamics.simulation.native import core_passive, core_source
from dynamics.torque_derivatives import _passive
from dynamics.torques import PD, ComputedTorque, Target
from tests.robots import erd

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CALLS = (_core.torque_source_derivatives, _core.closed_loop_derivatives)


def _core_args(model, source):
    src = make_source(model, source)
    assert src.slot < 0
    ps = _passive(model, None, None, 1e4, 100.0, 1e-3)
    return core_passive(model, ps), core_source(model, src)


@pytest.fixture(scope="module")
def two_r():
    return dynamics.load_urdf(os.path.join(REPO, "robots", "planar_2r.urdf"))


@pytest.fixture(scope="module")
def panda():
    return dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")


def _sources(model):
    q = np.full(model.nq, 0.1)
    t = np.array([0.0, 1.0])
    ref = np.stack([q, q + 0.1])
    frame = model.frame_names[-1]
    return [PD(q, 3.0, 1.0), ComputedTorque(t, ref, np.zeros_like(ref), np.zeros_like(ref), 10.0, 2.0),
            Target(frame, dynamics.frame_placement(model, q, frame)[:3, 3] + 0.01, kp=50.0, kd=10.0)]


@pytest.mark.parametrize("k", range(3))
def test_well_made_calls_match_the_public_functions(panda, k):
    source = _sources(panda)[k]
    passive, src = _core_args(panda, source)
    rng = np.random.default_rng(k)
    q, v = rng.uniform(-0.5, 0.5, panda.nq), rng.normal(size=panda.nv)
    n = panda.nv
    dq, dv = np.empty((n, n)), np.empty((n, n))
    assert _core.torque_source_derivatives(panda.core, passive, src, 0.3, q, v, dq, dv) is True
    ref = dynamics.torque_source_derivatives(panda, source, 0.3, q, v)
    assert np.array_equal(dq, ref[0]) and np.array_equal(dv, ref[1])
    assert _core.closed_loop_derivatives(panda.core, passive, src, 0.3, q, v, dq, dv) == -1
    ref = dynamics.closed_loop_derivatives(panda, source, 0.3, q, v)
    assert np.array_equal(dq, ref[0]) and np.array_equal(dv, ref[1])


def test_bad_arrays_are_refused(two_r):
    model = two_r
    n = model.nv
    passive, src = _core_args(model, PD(np.zeros(2), 1.0, 1.0))
    q, v = np.full(2, 0.2), np.full(2, 0.1)
    good = [model.core, passive, src, 0.0, q, v, np.empty((n, n)), np.empty((n, n))]

    def with_(k, value):
        a = list(good)
        a[k] = value
        return a

    big = np.empty((n, 2 * n))
    bad = [
        with_(4, q[:1]), with_(4, np.zeros(3)), with_(5, v[:1]), with_(5, np.zeros((2, 1))),  # shapes
        with_(4, q.astype(np.float32)), with_(5, v.astype(np.float32)),                       # float32
        with_(4, np.zeros(4)[::2]), with_(5, np.zeros(4)[::2]),                               # non-contiguous
        with_(4, [0.2, 0.2]), with_(5, None),                                                 # not arrays
        with_(4, np.array([np.nan, 0.0])), with_(5, np.array([0.0, np.inf])), with_(3, np.nan),  # not finite
        with_(6, np.empty((n, n + 1))), with_(7, np.empty((n + 1, n))), with_(6, np.empty(n * n)),  # outputs
        with_(6, np.empty((n, n), np.float32)), with_(7, big[:, ::2]), with_(6, np.empty((n, n), order="F")),
        with_(2, passive), with_(1, src), with_(2, None), with_(0, None),                     # wrong objects
    ]
    ro = np.empty((n, n))
    ro.flags.writeable = False
    bad.append(with_(6, ro))
    same = np.empty((n, n))
    bad.append([model.core, passive, src, 0.0, q, v, same, same])  # one array for both outputs
    for fn in CALLS:
        for args in bad:
            with pytest.raises((ValueError, TypeError)):
                fn(*args)
        assert fn(*good) in (True, -1)


def test_another_models_source_or_passive_is_refused(two_r, panda):
    passive, src = _core_args(two_r, PD(np.zeros(2), 1.0, 1.0))
    p_passive, p_src = _core_args(panda, PD(np.zeros(panda.nq), 1.0, 1.0))
    other = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")  # same sizes
    n = panda.nv
    q, v, out = np.zeros(panda.nq), np.zeros(n), (np.empty((n, n)), np.empty((n, n)))
    for fn in CALLS:
        with pytest.raises(ValueError, match="another model"):
            fn(panda.core, p_passive, src, 0.0, q, v, *out)          # a 2R source on Panda
        with pytest.raises(ValueError, match="another model"):
            fn(panda.core, passive, p_src, 0.0, q, v, *out)          # a 2R passive on Panda
        with pytest.raises(ValueError, match="another model"):
            fn(other.core, p_passive, p_src, 0.0, q, v, *out)        # Panda's source on another Panda
        assert fn(panda.core, p_passive, p_src, 0.0, q, v, *out) in (True, -1)


def test_zero_quaternion_is_refused():
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent", floating_base=True)
    passive, src = _core_args(model, PD(model.neutral(), 1.0, 1.0))
    q = model.neutral()
    q[3:7] = 0.0
    n = model.nv
    for fn in CALLS:
        with pytest.raises(ValueError, match="q"):
            fn(model.core, passive, src, 0.0, q, np.zeros(n), np.empty((n, n)), np.empty((n, n)))


def test_a_callables_errors_come_back(two_r):
    model = two_r
    n = model.nv
    ps = core_passive(model, _passive(model, None, None, 1e4, 100.0, 1e-3))
    q, v = np.full(2, 0.2), np.full(2, 0.1)

    def boom(t, q, v):
        raise RuntimeError("boom")

    for fn, match, err in ((boom, "boom", RuntimeError), (lambda t, q, v: np.zeros(3), "shape", InputError)):
        src = make_source(model, fn)
        try:
            for call in CALLS:
                with pytest.raises(err, match=match):
                    call(model.core, ps, core_source(model, src), 0.0, q, v, np.empty((n, n)), np.empty((n, n)))
        finally:
            release_callable(src.slot)
        for call in (dynamics.torque_source_derivatives, dynamics.closed_loop_derivatives):
            with pytest.raises(err, match=match):
                call(model, fn, 0.0, q, v)


def test_rotation_log_bounds():
    R = dynamics.spatial.rpy_to_matrix((0.3, -0.2, 1.1))
    w = _core.rotation_log(np.ascontiguousarray(R))
    theta = np.linalg.norm(w)
    K = np.cross(np.eye(3), w / theta)  # [axis]x: row k is e_k x axis
    assert np.allclose(np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K, R, atol=1e-14)  # Rodrigues
    for bad in (R[:2], R.astype(np.float32), np.asfortranarray(R), R.ravel(),
                np.full((3, 3), np.nan), [[1, 0, 0], [0, 1, 0], [0, 0, 1]], None):
        with pytest.raises((ValueError, TypeError)):
            _core.rotation_log(bad)


def test_source_torques_refuses_bad_input(two_r, panda):
    """_core.source_torques (the tests' evaluation of a source): the PD law at a good state; wrong shapes, dtypes,
    NaN and another model's source refused with a clear error."""
    ps, src = _core_args(two_r, PD(np.array([0.3, -0.2]), 3.0, 1.0))
    q, v, tau = np.array([0.1, 0.2]), np.array([0.5, -0.5]), np.empty(2)
    _core.source_torques(two_r.core, ps, src, 0.0, q, v, tau)
    np.testing.assert_allclose(tau, 3.0 * (np.array([0.3, -0.2]) - q) - 1.0 * v, rtol=1e-15)
    for args in [(q[:1], v, tau), (q, v.astype(np.float32), tau), (q, np.array([np.nan, 0.0]), tau),
                 (q, v, np.empty(3)), (q, v, np.empty(4)[::2])]:
        with pytest.raises((ValueError, TypeError)):
            _core.source_torques(two_r.core, ps, src, 0.0, *args)
    with pytest.raises(ValueError):
        _core.source_torques(panda.core, ps, src, 0.0, np.zeros(panda.nq), np.zeros(panda.nv), np.empty(panda.nv))
    with pytest.raises(ValueError):
        _core.source_torques(two_r.core, ps, src, np.nan, q, v, tau)
