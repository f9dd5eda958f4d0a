"""The bindings of the stepped simulator (bindings/simulator.cpp) refuse what would let the core write out of
bounds or read freed memory: arrays of the wrong dtype, rank, shape, layout or writability, a contact model per
environment (never one shared), indices out of range, non-finite torques.  In the sanitizer stage of .ci/run.
"""

import gc

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.simulation import native
from dynamics.simulation.simulator import _new_arrays
from robots import chain_urdf

MODEL = dynamics.load_urdf(chain_urdf(3))
SETTINGS = {"method": "rk4", "dt": 1e-3, "substep": 1e-3, "rtol": 1e-6, "atol": 1e-8, "max_steps": 100,
            "blowup": 1e6, "rerun": False, "order": 4}


def parts(model=MODEL):
    from dynamics.control.passive import Passive
    from dynamics.control.validation import make_source
    from dynamics.simulation.simulate import _qpos_map
    ps = Passive(np.zeros(model.nv), np.zeros(model.nv), 1e-3, 0, np.full(model.nv, -1.0), np.ones(model.nv),
                 _qpos_map(model), 1e4, 100.0, np.array([0, 0, -9.81]), np.zeros((0, 6)))
    return native.core_passive(model, ps), native.core_source(model, make_source(model, None))


def make(arrays=None, settings=SETTINGS, contacts=None, N=2):
    passive, source = parts()
    a = arrays if arrays is not None else _new_arrays(MODEL, N, contacts is not None, False)
    return _core.Simulator(MODEL.core, passive, source, None, None, contacts, None, settings, a), a


def test_a_good_one_steps():
    sim, a = make()
    a["tau"][:] = 0.1
    assert sim.step(1, float("inf")) == (0, 0, False, -1)
    assert np.all(a["t"] == 1e-3) and np.all(a["counters"][:, 0] == 1)


@pytest.mark.parametrize("key, bad", [
    ("q", np.zeros((2, 2))), ("q", np.zeros((2, 3), np.float32)), ("v", np.zeros((3, 3))),
    ("t", np.zeros((2, 1))), ("status", np.zeros(2)), ("counters", np.zeros((2, 3), np.int64)),
    ("clock", np.zeros((2, 3))), ("tau", np.zeros((2, 2))), ("w", np.zeros((2, 3))),
    ("q", np.zeros((2, 6))[:, ::2]), ("drift", np.zeros((2, 3))),
])
def test_wrong_arrays(key, bad):
    a = _new_arrays(MODEL, 2, False, False)
    a[key] = bad
    with pytest.raises((ValueError, TypeError), match=key):
        make(a)


def test_read_only_arrays_are_refused():
    a = _new_arrays(MODEL, 2, False, False)
    a["q"].flags.writeable = False
    with pytest.raises((ValueError, TypeError), match="q"):
        make(a)


@pytest.mark.parametrize("change, match", [
    (dict(method="rk5"), "method"), (dict(dt=0.0), "dt"), (dict(dt=np.inf), "dt"), (dict(substep=0.0), "substep"),
    (dict(substep=1e-15), "substep"), (dict(rtol=0.0), "rtol"), (dict(max_steps=0), "max_steps"),
    (dict(order=9), "order"), (dict(order=-1), "order"),
])
def test_wrong_settings(change, match):
    with pytest.raises(ValueError, match=match):
        make(settings={**SETTINGS, **change})


def test_one_contact_model_per_environment():
    from dynamics.contact.resolve import core_contact, resolve
    model = MODEL
    r = resolve(dynamics.Contact(geometries=[dynamics.Sphere(model.body_names[-1], 0.05)]), model)
    one = core_contact(r, model).core
    with pytest.raises(ValueError, match="one contact model per environment"):
        make(_new_arrays(model, 2, True, False), contacts=[one, one])
    with pytest.raises(ValueError, match="one contact model per environment"):
        make(_new_arrays(model, 2, True, False), contacts=[one])
    # with the error estimate's rerun: one more per environment, for its shadow
    cms = [core_contact(r, model).core for _ in range(4)]
    with pytest.raises(ValueError, match="and shadow"):
        make(_new_arrays(model, 2, True, False), contacts=cms[:2], settings={**SETTINGS, "rerun": True})
    with pytest.raises(ValueError, match="and shadow"):
        make(_new_arrays(model, 2, True, False), contacts=cms[:3] + cms[:1], settings={**SETTINGS, "rerun": True})
    sim, a = make(_new_arrays(model, 2, True, False), contacts=cms, settings={**SETTINGS, "rerun": True})
    sim.step(1, float("inf"))
    assert np.all(a["error"] >= 0)


def test_load_and_torques():
    sim, a = make()
    with pytest.raises(ValueError, match="which"):
        sim.load(np.array([2], np.int64))
    with pytest.raises(ValueError, match="which"):
        sim.load(np.array([-1], np.int64))
    a["tau"][1, 2] = np.nan
    assert sim.step(1, float("inf"))[3] == 1 * MODEL.nv + 2  # found before anything is stepped
    assert np.all(a["t"] == 0.0)


def test_the_arrays_outlive_the_callers_references():
    sim, a = make()
    q = a["q"]
    a["q"] = np.zeros((2, MODEL.nq))  # the dict no longer holds the array the core writes into
    del a, q
    gc.collect()
    sim.step(1, float("inf"))  # (under AddressSanitizer: no use after free)
