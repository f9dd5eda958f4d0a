"""The clearance bound (dynamics.contact.clearance): how far the robot can have moved since the reference state,
by which the simulation's right-hand side skips the contact code.  Checked against the true displacement of
every body origin and geometry centre along random chart steps on random trees of every joint type (floating,
planar, spherical and prismatic included), over one step and accumulated over many; against the true
separation of the bounding volumes when it says "apart"; and for tightness on a lever, where a bound that is
sound but useless (or a lever taken from the wrong body) would show."""

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.contact.narrow_phase import scene_poses
from dynamics.contact.resolve import core_contact, resolve
from dynamics.contact.scene import PLANE
from robots import ALL_TYPES, random_state, random_urdf


def _scene(model, rng):
    """A sphere on every other body at a random offset, self-collision on, and the ground."""
    geoms = [dynamics.Sphere(name, float(rng.uniform(0.02, 0.1)), tuple(rng.uniform(-0.4, 0.4, 3)))
             for name in model.body_names[::2]]
    return resolve(dynamics.Contact(ground=dynamics.Ground(height=-3.0), geometries=geoms, self_collision=True),
                   model)


def _points(model, scene, q):
    """Every body origin and geometry centre in the world at q."""
    op = np.array([dynamics.frame_placement(model, q, name)[:3, 3] for name in model.body_names])
    return np.vstack([op, scene_poses(model, scene, q)[scene.body >= 0, :3, 3]])


def _separation(model, scene, q):
    """The smallest separation of the candidate pairs' bounding volumes at q, from Python."""
    P = scene_poses(model, scene, q)
    g = np.inf
    for a, b in zip(scene.pair_a, scene.pair_b):
        ca = P[a, :3, 3]
        if scene.kind[b] == PLANE:  # its z axis is its normal
            n = P[b, :3, 2]
            g = min(g, n @ ca - n @ P[b, :3, 3] - scene.radius[a])
        else:
            g = min(g, np.linalg.norm(ca - P[b, :3, 3]) - scene.radius[a] - scene.radius[b])
    return g


def _reference(model, resolved, q):
    """The core's clearance (a run's contact, core/contact/clearance.hpp) with q as its reference."""
    cl = core_contact(resolved, model).core
    cl.set_reference(q)
    return cl


def _retracted(model, q0, delta):
    q = np.empty(model.nq)
    _core.retract(model.core, q0, delta, q)
    return q


@pytest.mark.parametrize("seed", range(4))
def test_bound_holds_over_one_step_and_many(seed):
    """|x(q0 (+) delta) - x(q0)| <= moved(delta) for every point, steps of every size along random and
    single-joint directions; and through ten rebased steps, the accumulated bound covers the motion since the
    reference."""
    rng = np.random.default_rng(seed)
    model = dynamics.load_urdf(random_urdf(rng, 7, types=ALL_TYPES, floating_joint=seed % 2 == 0))
    resolved = _scene(model, rng)
    scene = resolved.scene
    q0, _, _ = random_state(model, rng)
    x0 = _points(model, scene, q0)
    cl = _reference(model, resolved, q0)
    assert cl.clearance[0] == pytest.approx(_separation(model, scene, q0), rel=1e-12, abs=1e-12)
    worst = 0.0
    for trial in range(100):
        delta = np.zeros(model.nv)
        if trial % 3 == 0:  # one dof: the steepest direction of a single joint
            delta[rng.integers(model.nv)] = 1.0
        else:
            delta = rng.normal(size=model.nv)
        delta *= 10.0 ** rng.uniform(-4, 0) / np.linalg.norm(delta)
        true = np.linalg.norm(_points(model, scene, _retracted(model, q0, delta)) - x0, axis=1).max()
        D = cl.moved(delta)
        assert true <= D * (1 + 1e-9) + 1e-12  # (apart's own margins for the round-off of the points)
        if D > 0:
            worst = max(worst, true / D)
    assert worst > 0.2  # the bound is not vacuous on these trees
    # many steps, each in the chart of the last accepted state
    q = q0.copy()
    for _ in range(10):
        delta = rng.normal(size=model.nv) * 0.03
        cl.advance(delta)
        q = _retracted(model, q, delta)
        true = np.linalg.norm(_points(model, scene, q) - x0, axis=1).max()
        assert true <= cl.clearance[1] * (1 + 1e-9) + 1e-12


def test_apart_means_the_broad_phase_finds_nothing():
    """Wherever ``apart`` says so, the bounding volumes are separated; and it says so for steps small against
    the reference's separation, so the skip happens."""
    rng = np.random.default_rng(7)
    said = 0
    for _ in range(5):
        model = dynamics.load_urdf(random_urdf(rng, 6, types=ALL_TYPES, floating_joint=True))
        resolved = _scene(model, rng)
        scene = resolved.scene
        q0, _, _ = random_state(model, rng)
        cl = _reference(model, resolved, q0)
        for _ in range(40):
            delta = rng.normal(size=model.nv)
            delta *= 10.0 ** rng.uniform(-5, 0) / np.linalg.norm(delta)
            if cl.apart(delta):
                said += 1
                assert _separation(model, scene, _retracted(model, q0, delta)) > 0
    assert said > 20
    # a non-finite step is never apart
    assert not cl.apart(np.full(model.nv, np.nan))


LEVER = """<robot name="lever">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tip"><inertial><mass value="1"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-5" upper="5" effort="1" velocity="1"/></joint>
  <joint name="slide" type="prismatic"><parent link="arm"/><child link="tip"/><origin xyz="1.5 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-5" upper="5" effort="1" velocity="1"/></joint>
</robot>"""


def test_bound_is_tight_on_a_lever():
    """A ball 2 m out on a hinge (1.5 m arm, 0.5 m offset): turning by theta moves it 2 sin(theta/2) * 2 m,
    and the bound is 2 theta / (1 - 2 theta), within 3 % at theta = 0.01; the slide adds its length
    exactly."""
    model = dynamics.load_urdf(LEVER)
    resolved = resolve(dynamics.Contact(ground=dynamics.Ground(height=-0.2),
                                        geometries=[dynamics.Sphere("tip", 0.1, (0.5, 0.0, 0.0))]), model)
    q0 = np.zeros(model.nq)
    cl = _reference(model, resolved, q0)
    assert cl.clearance[0] == pytest.approx(0.1, abs=1e-12)  # the ball's height above the ground minus its radius
    theta = 0.01
    true = 2 * np.sin(theta / 2) * 2.0
    assert true <= cl.moved(np.array([theta, 0.0])) <= 1.03 * true
    assert cl.moved(np.array([0.0, 0.02])) == pytest.approx(0.02, rel=1e-12)
    assert cl.apart(np.array([0.0, 0.04])) and not cl.apart(np.array([0.0, 0.06]))
