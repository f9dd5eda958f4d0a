"""A run's contact in the core (core/contact/contact_model.cpp, bindings/contact_model.cpp) made directly through
the extension with what no public function passes: wrong shapes, arrays of the wrong dtype, non-contiguous or
read-only outputs (the scene's arrays are read in place, checked as find_contacts checks them; the material rows
of another dtype are converted, and the copies kept with the model),
indices out of range, unordered pairs, a contact made for another model.  A clear error, never a crash or a read
or write out of bounds (the sanitizer stage runs this file); and a well-made one evaluates and simulates."""

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.contact.resolve import core_contact, resolve

BALL = """<robot name="ball"><link name="ball"><inertial><mass value="1"/>
<inertia ixx="0.004" iyy="0.004" izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""


@pytest.fixture(scope="module")
def ball():
    model = dynamics.load_urdf(BALL, floating_base=True)
    contact = dynamics.Contact(geometries=[dynamics.Sphere("ball", 0.1), dynamics.Box("ball", (0.1, 0.2, 0.1))],
                               outputs=("contacts",))
    return model, resolve(contact, model)


def _args(model, r, T=4):
    S = r.scene
    K = int(S.max_contacts)
    return [model.core, S.body, S.kind, S.size, S.R, S.p, S.radius, S.pair_a, S.pair_b, r.pair_body, r.mat, K,
            np.zeros(3), np.zeros((T, K, 15)), np.zeros(T, np.int64), False]


def test_a_well_made_contact_evaluates(ball):
    model, r = ball
    c = _core.ContactModel(*_args(model, r))
    q = np.array([0, 0, 0.09, 0, 0, 0, 1.0])
    f_ext, tau = np.zeros((model.nbodies, 6)), np.zeros(model.nv)
    power, pair, point, normal, depth, detail = c.evaluate(q, np.zeros(6), f_ext, tau)
    assert pair.dtype == np.int64 and len(pair) == len(depth) >= 1 and detail.shape == (len(pair), 8)
    assert np.all(depth > 0) and f_ext[0, 2] > 0 and tau[2] > 0  # pushed up


def test_inconsistent_arrays_are_refused(ball):
    model, r = ball
    args = _args(model, r)
    K = args[11]

    def with_(k, value):
        a = list(args)
        a[k] = value
        return a

    bad = [
        with_(1, np.full_like(args[1], 5)),                      # body out of the model's range
        with_(2, np.full_like(args[2], 9)),                      # unknown kind
        with_(3, args[3][:1]),                                   # size: too few rows
        with_(4, np.ascontiguousarray(args[4][:, :2])),          # R: (ng, 2, 3)
        with_(7, np.full_like(args[7], 99)),                     # pair_a out of range
        with_(8, args[8][:0]),                                   # pair_b shorter than pair_a
        with_(7, args[8].copy()) if args[2][args[8][0]] != args[2][args[7][0]] else with_(9, args[9][:, :1]),
        with_(9, args[9] + 1),                                   # pair_body: not the geometries' bodies
        with_(10, args[10][:, :4]),                              # mat: (npairs, 4)
        with_(11, -1),                                           # K < 0
        with_(11, 10**9),                                        # K beyond 8 per pair
        with_(12, np.zeros(2)),                                  # track: (2,)
        with_(13, np.zeros((4, K + 1, 15))),                     # out: wrong K
        with_(13, np.zeros((4, K, 15), np.float32)),             # out: float32 (a copy would be written and lost)
        with_(13, np.zeros((4, K, 30))[:, :, ::2]),              # out: not contiguous
        with_(14, np.zeros(3, np.int64)),                        # out_n: (T - 1,)
        with_(0, "model"),                                       # not a model
    ]
    for b in bad:
        with pytest.raises((ValueError, TypeError)):
            _core.ContactModel(*b)
    ro = np.zeros(3)
    ro.flags.writeable = False
    with pytest.raises((ValueError, TypeError)):
        _core.ContactModel(*with_(12, ro))


def test_evaluate_and_derivatives_refuse_wrong_shapes(ball):
    model, r = ball
    c = _core.ContactModel(*_args(model, r))
    q, v = np.array([0, 0, 0.09, 0, 0, 0, 1.0]), np.zeros(6)
    f_ext, tau = np.zeros((model.nbodies, 6)), np.zeros(model.nv)
    for args in [(q[:6], v, f_ext, tau), (q, v[:5], f_ext, tau), (q, v, f_ext[:, :5], tau), (q, v, f_ext, tau[:5]),
                 (q, v, f_ext.astype(np.float32), tau), (q, v, f_ext, np.zeros(12)[::2])]:
        with pytest.raises((ValueError, TypeError)):
            c.evaluate(*args)
    for args in [(q, v, np.zeros((6, 5)), np.zeros((6, 6))), (q, v, np.zeros((6, 6)), np.zeros(36))]:
        with pytest.raises((ValueError, TypeError)):
            c.force_derivatives(*args)
    with pytest.raises(ValueError):
        c.moved(np.zeros(5))


def test_hand_made_lists_are_checked(ball):
    model, _ = ball
    q, v = np.array([0, 0, 0.09, 0, 0, 0, 1.0]), np.zeros(6)
    good = dict(pair_body=np.array([[0, -1]], np.int64), mat=np.array([[1e4, 1.0, 1.0, 1.0, 1e-3]]),
                point=np.zeros((1, 3)), normal=np.array([[0, 0, 1.0]]), depth=np.array([1e-3]))
    out = lambda K: (np.zeros((model.nbodies, 6)), np.zeros(model.nv), np.zeros((K, 8)))  # noqa: E731
    assert _core.contact_wrenches(model.core, q, v, **good, f_ext=out(1)[0], tau=out(1)[1], detail=out(1)[2]) == 0.0
    for key, value in [("pair_body", np.array([[3, -1]], np.int64)), ("pair_body", np.array([[0, -2]], np.int64)),
                       ("mat", np.array([[1e4, 1.0, 1.0, 1.0, 0.0]])), ("point", np.zeros((2, 3))),
                       ("depth", np.zeros(3))]:
        with pytest.raises((ValueError, TypeError)):
            _core.contact_wrenches(model.core, q, v, **dict(good, **{key: value}), f_ext=out(1)[0], tau=out(1)[1],
                                   detail=out(1)[2])
    with pytest.raises(ValueError):
        _core.contact_wrenches(model.core, q, v, **good, f_ext=out(1)[0], tau=out(1)[1], detail=out(2)[2])


def test_the_simulation_refuses_a_contact_made_for_another_model(ball, monkeypatch):
    """simulate's call of the core's run, repeated with a contact of another model and without its W_contact."""
    model, r = ball
    captured = {}
    real = _core.run

    def spy(*args):
        captured["args"] = args
        return real(*args)

    monkeypatch.setattr(_core, "run", spy)
    q0, v0 = np.array([0, 0, 0.2, 0, 0, 0, 1.0]), np.array([0, 0, -1.0, 0, 0, 0])
    traj = dynamics.simulate(model, q0, v0, 0.3, contact=r.contact, integrator="rk4", dt=1e-4, error_estimate="none",
                             progress=False)
    assert traj.q[-1, 2] > 0.05 and traj.report["contact"]["max_penetration"] > 0  # it bounced
    *args, contact = captured["args"]
    other = dynamics.load_urdf(BALL, floating_base=True)
    with pytest.raises(ValueError):
        real(*args, core_contact(resolve(r.contact, other), other).core)
    with pytest.raises(TypeError):
        real(*args, "contact")
    with pytest.raises(ValueError):  # out_w without the contact's column
        real(*args[:12], args[12][:, :2].copy(), *args[13:], contact)


def test_collide_at_refuses_bad_poses(ball):
    """_core.collide_at (the narrow phase at given body poses): poses of the wrong shape or dtype are a clear
    error; NaN poses give a bounded answer."""
    model, r = ball
    S = r.scene
    good = np.tile(np.eye(4), (model.nbodies, 1, 1))
    assert len(_core.collide_at(model.core, *S.arrays, good, S.max_contacts)[0]) >= 0
    for poses in (good[:, :3], np.tile(np.eye(4), (model.nbodies + 1, 1, 1)), good.astype(np.float32),
                  np.zeros((model.nbodies, 4, 8))[:, :, ::2]):
        with pytest.raises(ValueError):
            _core.collide_at(model.core, *S.arrays, poses, S.max_contacts)
    pair = _core.collide_at(model.core, *S.arrays, np.full_like(good, np.nan), S.max_contacts)[0]
    assert len(pair) <= S.max_contacts
