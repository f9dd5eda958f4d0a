"""simulate's fast paths (its fixed cost, issue 46) give what the general paths give, bit for bit, and the same
errors: the energy balance of a few samples in Python floats against numpy's, the checks' fast paths against
their general paths, the sample times against their first formula, and the per-model caches' keys."""

import importlib
import math

import numpy as np
import pytest

import dynamics
from dynamics.checks import real_number, vector
from dynamics.control import validation
from dynamics.errors import InputError
from dynamics.simulation import native
from dynamics.simulation import report as R

S = importlib.import_module("dynamics.simulation.simulate")


@pytest.fixture(scope="module")
def panda():
    return dynamics.load_urdf(dynamics.robots.example_robot_data("panda_description/urdf/panda.urdf"),
                              mimic="independent")


def _numpy_terms(e, w):
    """The energy balance's terms as numpy computes them (the many-sample path)."""
    K, U = e[:, 0], e[:, 1]
    E = K + U
    resid = np.abs(E - E[0] - w.sum(axis=1))
    return (float(K.max()), float(U.max() - U.min()), float(np.abs(w[-1]).max()), float(resid[-1]),
            float(resid.max()), float(E[0]), float(E[-1]))


def test_energy_balance_fields_for_few_and_many_samples(panda):
    """report.energy_balance against the first formula, for a few samples and many."""
    s = S._settings(panda, panda.neutral(), np.zeros(panda.nv), 1e-3, "rk4", 1e-6, 1e-8, 1e-4, None, None, 10 ** 6,
                    "none", S.DEFAULT_OUTPUTS, [], None, False)
    rng = np.random.default_rng(3)
    for cnt in (1, 2, 16, 17, 200):
        e, w = rng.normal(size=(cnt, 2)), rng.normal(size=(cnt, 2))
        got = R.energy_balance(panda, s, e, w)
        k, urange, wmax, last, big, e0, e1 = _numpy_terms(e, w)
        scale = max(k, urange, wmax, R.robot_energy_scale(panda, s.gravity))
        assert got["energy_scale"] == scale and got["energy_drift"] == float(last / scale)
        assert got["energy_drift_max"] == float(big / scale)
        assert (got["energy_initial"], got["energy_final"]) == (e0, e1)


def test_vector_and_real_number_fast_paths_match_the_general_ones():
    x = np.array([1.0, -2.0, 3.5])
    ro = x.copy()
    ro.flags.writeable = False
    for arg in (x, ro, x.tolist(), x.astype(np.float32)):
        got = vector("v0", arg, 3)
        assert got.dtype == np.float64 and got.flags.c_contiguous and got.flags.writeable
        assert np.array_equal(got, x.astype(np.asarray(arg).dtype).astype(float)) and got is not arg
    for bad in (np.array([1.0, np.nan, 0.0]), [1.0, np.inf, 0.0]):
        with pytest.raises(InputError, match=r"v0: contains non-finite values \(nan or inf\)"):
            vector("v0", bad, 3)
    for value, kw in ((0.0, dict(lo=0.0)), (1e-14, dict(lo=1e-14, hi=1.0)), (2.5, {})):
        assert real_number("x", value, **kw) == value and type(real_number("x", value, **kw)) is float
    for value, kw, message in ((0.0, dict(lo=0.0, lo_open=True), "expected a value > 0"),
                               (1.0, dict(lo=1e-14, hi=1.0), "expected a value < 1"),
                               (-1.0, dict(lo=0.0), "expected a value >= 0"),
                               (math.nan, {}, "expected a finite real number"),
                               (math.inf, dict(lo=0.0), "expected a finite real number")):
        with pytest.raises(InputError, match=message):
            real_number("x", value, **kw)
    assert type(real_number("x", np.float64(2.0), lo=0.0)) is float


def test_source_arrays_fast_paths_match_the_general_ones():
    for x in (200.0, 3, np.full(4, 2.0), [1.0, 2.0, 3.0, 4.0], np.arange(4.0)[::-1]):
        got = validation._array("torque.kp", x, (4,), nonneg=True)
        assert got.dtype == np.float64 and got.flags.c_contiguous and got.flags.writeable
        assert np.array_equal(got, np.broadcast_to(np.asarray(x, float), (4,)))
    for x, message in ((-1.0, "expected values >= 0"), (np.array([1.0, -1.0, 0, 0]), "expected values >= 0"),
                       (math.inf, "contains non-finite values"), (np.array([1.0, np.nan, 0, 0]), "contains non-finite values")):
        with pytest.raises(InputError, match=f"torque.kp: {message}"):
            validation._array("torque.kp", x, (4,), nonneg=True)
    with pytest.raises(InputError, match=r"torque.kp: expected shape \(4,\), got \(3,\)"):
        validation._array("torque.kp", np.ones(3), (4,))


def _sample_times_first(duration, dt, sample_dt, fixed):
    """The sample times as first written (numpy throughout)."""
    if sample_dt is None:
        if fixed:
            n = max(1, math.ceil(duration / dt * (1 - 1e-12))) if duration > 0 else 0
            t = np.minimum(np.arange(n + 1) * dt, duration)
            t[-1] = duration
            return t
        sample_dt = duration / 1000 if duration > 0 else 1.0
    n = math.floor(duration / sample_dt * (1 + 1e-12))
    t = np.arange(n + 1) * sample_dt
    t = t[t < duration * (1 - 1e-12)] if duration > 0 else t[:1]
    return np.append(t, duration) if duration > 0 else t


def test_sample_times_are_the_first_formulas():
    rng = np.random.default_rng(11)
    for _ in range(3000):
        duration = float(rng.choice([0.0, 1e-4, 1e-3, 0.3, 1.0, 7.3])) * float(rng.uniform(0.5, 1.5))
        dt = float(rng.choice([1e-4, 1e-3, 0.1])) if not duration else duration / float(rng.choice([1, 3, 7, 15.5, 16, 17]))
        sample_dt = None if rng.random() < 0.5 else float(rng.choice([1e-4, 0.01, 0.5])) * float(rng.uniform(0.5, 2))
        for fixed in (True, False):
            a, b = _sample_times_first(duration, dt, sample_dt, fixed), S._sample_times(duration, dt, sample_dt, fixed)
            assert a.shape == b.shape and a.tobytes() == b.tobytes(), (duration, dt, sample_dt, fixed)


def test_the_core_passive_is_kept_per_model_and_parameters(panda):
    s = S._settings(panda, panda.neutral(), np.zeros(panda.nv), 1e-3, "auto", 1e-6, 1e-8, None, None, None, 10 ** 6,
                    "rerun", S.DEFAULT_OUTPUTS, [], None, False)
    ps = S._passive(panda, s, None, 1e4, 100.0, 1e-3)
    core = native.core_passive(panda, ps)
    assert native.core_passive(panda, S._passive(panda, s, None, 1e4, 100.0, 1e-3)) is core
    assert native.core_passive(panda, S._passive(panda, s, "spring", 1e4, 100.0, 1e-3)) is not core
    assert native.core_passive(panda, S._passive(panda, s, None, 1e4, 100.0, 2e-3)) is not core
    other = s._replace(gravity=np.array([0.0, 0.0, -1.62]))
    assert native.core_passive(panda, S._passive(panda, other, None, 1e4, 100.0, 1e-3)) is not core
    copied = ps._replace(damping=ps.damping.copy())  # arrays that could change: made again
    assert native.core_passive(panda, copied) is not native.core_passive(panda, copied)
    twin = dynamics.load_urdf(dynamics.robots.example_robot_data("panda_description/urdf/panda.urdf"),
                              mimic="independent")
    assert native.core_passive(twin, S._passive(twin, s, None, 1e4, 100.0, 1e-3)) is not core


def test_repeated_calls_give_the_same_bits(panda):
    """The caches and the reused core objects change nothing between calls (nor a gravity's per-call scale)."""
    pd = dynamics.torques.PD(panda.neutral() + 0.2, 200.0, 20.0)
    q0, v0 = panda.neutral() + 0.1, np.zeros(panda.nv)
    runs = [dynamics.simulate(panda, q0, v0, 2e-3, torque=pd, gravity=g, progress=False)
            for g in (None, [0, 0, -1.62], None)]
    a, b = runs[0], runs[2]
    assert all(np.array_equal(x, y) for x, y in zip(a[:4], b[:4]))
    keep = {k: v for k, v in a.report.items() if "wall_time" not in k and k != "cost_of_estimate"}
    assert keep == {k: b.report[k] for k in keep}
    assert runs[1].report["energy_scale"] != runs[0].report["energy_scale"]


@pytest.mark.parametrize("nquad", [2, 3])
def test_the_balance_is_numpys(nquad):
    """The core's one pass (_core.energy_balance_terms) against numpy's operations, bit for bit: zeros of either
    sign, NaN and inf included (numpy's max and min: a NaN anywhere is the result)."""
    from dynamics import _core
    rng = np.random.default_rng(11)
    for trial in range(600):
        cnt = int(rng.integers(1, 300))
        scale = 10.0 ** rng.integers(-8, 8, size=(cnt, 1))
        e = rng.normal(size=(cnt, 2)) * scale
        w = rng.normal(size=(cnt, nquad)) * scale
        if trial % 5 == 0:
            e[:, 0] = np.abs(e[:, 0])
            e[0] = -0.0
        if trial % 7 == 0:
            for _ in range(int(rng.integers(1, 3))):
                a = e if rng.random() < 0.5 else w
                a.flat[int(rng.integers(a.size))] = rng.choice([np.nan, np.inf, -np.inf])
        with np.errstate(invalid="ignore", over="ignore"):
            want = _numpy_terms(e, w)
        got = _core.energy_balance_terms(e, w)
        assert np.array(got).tobytes() == np.array(want).tobytes()
