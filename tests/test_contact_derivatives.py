"""The contact force's derivatives for the simulation's Jacobian (dynamics.contact.force_derivatives): d tau_c/dv
is exact, checked against central differences of the force law on random trees of every joint type, in each
regime of the friction curve; d tau_c/dq is the contact's stiffness, exact where the contact Jacobian is constant
(Cartesian joints against a plane) and checked there against differences of the whole evaluation (narrow phase
included)."""

import numpy as np
import pytest

import dynamics
from dynamics.contact.force_derivatives import force_derivatives_of
from dynamics.contact.forces import contact_wrenches
from robots import ALL_TYPES, random_state, random_urdf, vector_fd

#: k, d, mu_s, mu_d, v_s
MAT = np.array([1e4, 2.0, 0.8, 0.5, 1e-2])


def _tau_c(model, q, v, pair_body, point, normal, depth, mat):
    """tau_c for a fixed contact list."""
    return contact_wrenches(model, q, v, pair_body, point, normal, depth, mat)[1]


def _point_jacobian(model, q, body, P):
    """(3, nv): the world velocity of body's material point at the world point P per unit of each velocity
    (zero for the world, body -1), from the public frame Jacobian at the body's origin o: v_P = v_o + w x (P - o)."""
    if body < 0:
        return np.zeros((3, model.nv))
    name = model.body_names[body]
    J = dynamics.frame_jacobian(model, q, name)
    r = P - dynamics.frame_placement(model, q, name)[:3, 3]
    rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    return J[:3] - rx @ J[3:]


@pytest.mark.parametrize("s", [1e-3, 0.5, 2.0, 5.0], ids=["near-rest", "stiction", "stribeck", "sliding"])
def test_velocity_derivative_is_exact(s):
    """d tau_c/dv against central differences (relative 1e-6) for contacts between bodies and with the world on
    a random tree of every joint type, each contact's stiction velocity set so that its slip ratio |v_t| / v_s is
    ``s`` (each branch of mu(s)), and its dissipation so that one in three approaches (damping active), one
    separates slowly and one fast enough that (1 - d v_n)_+ clamps."""
    rng = np.random.default_rng(11)
    model = dynamics.load_urdf(random_urdf(rng, 6, types=ALL_TYPES, floating_joint=True))
    nb = model.tree.parents.shape[0]
    q, v, _ = random_state(model, rng)
    K = 6
    pair_body = np.array([rng.choice(np.arange(-1, nb), 2, replace=False) for _ in range(K)], np.int64)
    pair_body[pair_body[:, 0] < 0] = pair_body[pair_body[:, 0] < 0, ::-1]  # a is a body
    normal = rng.normal(size=(K, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    point, depth = rng.normal(size=(K, 3)), rng.uniform(1e-4, 1e-2, K)
    mat = np.tile(MAT, (K, 1))
    for k in range(K):
        Ak = _point_jacobian(model, q, pair_body[k, 0], point[k]) - _point_jacobian(model, q, pair_body[k, 1], point[k])
        vrel = Ak @ v
        vn = normal[k] @ vrel
        if k % 3 and vn < 0:  # separating ones: flip the normal
            normal[k], vn = -normal[k], -vn
        if k % 3 == 0 and vn > 0:
            normal[k], vn = -normal[k], -vn
        mat[k, 4] = np.linalg.norm(vrel - vn * normal[k]) / s  # v_s
        mat[k, 1] = (0.5, 0.5, 2.0)[k % 3] / abs(vn)  # d v_n: -0.5 (approaching), 0.5, 2 (clamped)
    dq, dv = force_derivatives_of(model, q, v, pair_body, point, normal, depth, mat)
    fd = vector_fd(lambda x: _tau_c(model, q, x, pair_body, point, normal, depth, mat), v, 1e-7)
    assert np.abs(dv - fd).max() <= 1e-6 * np.abs(fd).max()


CARTESIAN = """<robot name="xyz">
  <link name="base"/>
  <link name="lx"><inertial><mass value="1"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="ly"><inertial><mass value="1"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tool"><inertial><mass value="2"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="x" type="prismatic"><parent link="base"/><child link="lx"/><axis xyz="1 0 0"/>
    <limit lower="-5" upper="5" effort="1" velocity="1"/></joint>
  <joint name="y" type="prismatic"><parent link="lx"/><child link="ly"/><axis xyz="0 1 0"/>
    <limit lower="-5" upper="5" effort="1" velocity="1"/></joint>
  <joint name="z" type="prismatic"><parent link="ly"/><child link="tool"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-5" upper="5" effort="1" velocity="1"/></joint>
</robot>"""


@pytest.mark.parametrize("normal", [(0.0, 0.0, 1.0), (0.3, -0.2, 0.9)], ids=["ground", "incline"])
@pytest.mark.parametrize("speed", [3e-3, 0.2], ids=["stiction", "sliding"])
def test_configuration_derivative_where_exact(normal, speed):
    """A sphere on Cartesian joints against a ground or an incline: the contact Jacobian is constant, so the
    stiffness part is all of d tau_c/dq; both derivatives against central differences of the whole evaluation
    (narrow phase, force law, backward pass), relative 1e-6."""
    from dynamics.contact.resolve import core_contact, resolve
    model = dynamics.load_urdf(CARTESIAN)
    n = np.array(normal) / np.linalg.norm(normal)
    contact = dynamics.Contact(ground=dynamics.Ground(normal=tuple(n), height=0.0),
                               geometries=[dynamics.Sphere("tool", 0.05)],
                               friction=dynamics.Material(stiffness=2e4, dissipation=1.5, mu_static=0.9,
                                                          mu_dynamic=0.6, stiction_velocity=1e-2))
    t = np.cross(n, [1.0, 0.0, 0.0])
    t /= np.linalg.norm(t)
    # the tool's origin 0.04 m along the normal: 1 cm deep; moving into the plane at 3 cm/s and along t
    Jp = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0.6, 0.8]]).T  # tool velocity = Jp v
    q = np.linalg.solve(Jp, 0.04 * n)
    v = np.linalg.solve(Jp, -0.03 * n + speed * t)

    def tau(qq, vv):
        f_ext, det = dynamics.contact_forces(model, contact, qq, vv, details=True)
        return det.generalized_force

    r = resolve(contact, model)
    dq, dv = np.empty((3, 3)), np.empty((3, 3))
    core_contact(r, model).core.force_derivatives(q, v, dq, dv)
    fd_q = vector_fd(lambda x: tau(x, v), q, 1e-7)
    fd_v = vector_fd(lambda x: tau(q, x), v, 1e-7)
    assert np.abs(dq - fd_q).max() <= 1e-6 * np.abs(fd_q).max()
    assert np.abs(dv - fd_v).max() <= 1e-6 * np.abs(fd_v).max()
