"""dynamics.check_inertias against closed forms: a uniform box's moments give back its edges, the principal axes
diagonalise the inertia, and inertias no rigid body can have are flagged as load_urdf flags them."""

import numpy as np
import pytest

import dynamics

BOX = """<robot name="box"><link name="world_link"/>
<link name="slab"><inertial><origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.5 1.1"/><mass value="{m}"/>
<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="hinge" type="revolute"><parent link="world_link"/><child link="slab"/><axis xyz="0 0 1"/>
<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""


def box_urdf(m, a, b, c):
    """A uniform a x b x c box of mass m, its principal axes turned by rpy (0.3, -0.5, 1.1) in the body frame."""
    return BOX.format(m=m, ixx=m * (b * b + c * c) / 12, iyy=m * (a * a + c * c) / 12, izz=m * (a * a + b * b) / 12)


def test_a_uniform_box_gives_back_its_edges_and_axes():
    m, edges = 2.5, np.array([0.4, 0.1, 0.25])
    model = dynamics.load_urdf(box_urdf(m, *edges))
    (check,) = dynamics.check_inertias(model)
    assert check.body == "slab" and check.mass == pytest.approx(m)
    assert check.verdict == "ok" and check.positive_definite and check.triangle
    # the moments ascend, so the longest edge goes with the smallest moment
    order = np.argsort(-edges)
    np.testing.assert_allclose(check.box, edges[order], rtol=1e-12)
    R = check.principal_axes
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(R.T @ check.inertia @ R, np.diag(check.principal_moments), atol=1e-14)
    np.testing.assert_allclose(check.com, [0.1, -0.2, 0.3], atol=1e-15)
    # the first principal axis is the box's x axis turned by the inertial origin's rpy (up to its sign)
    Rx = dynamics.spatial.rpy_to_matrix(np.array([0.3, -0.5, 1.1]))
    assert abs(R[:, 0] @ Rx[:, 0]) == pytest.approx(1.0, abs=1e-12)


def test_inertias_no_body_can_have_are_flagged_as_load_urdf_flags_them():
    # principal moments (1, 1, 3): I3 > I1 + I2, which load_urdf refuses unless strict_inertia=False
    text = BOX.format(m=1.0, ixx=1.0, iyy=1.0, izz=3.0)
    with pytest.raises(dynamics.URDFError, match="triangle inequality"):
        dynamics.load_urdf(text)
    model = dynamics.load_urdf(text, strict_inertia=False)
    (check,) = dynamics.check_inertias(model)
    assert not check.triangle and check.positive_definite
    assert check.relative_violation == pytest.approx((3.0 - 1.0 - 1.0) / 5.0)
    assert check.verdict == "refused"
    assert check.box[2] == 0.0  # 6 (I1 + I2 - I3) / m < 0: no box has it
    # a slight excess, within load_urdf's warning band
    model = dynamics.load_urdf(BOX.format(m=1.0, ixx=1.0, iyy=1.0, izz=2.001))
    (check,) = dynamics.check_inertias(model)
    assert check.verdict == "warning" and not check.triangle
    assert any("triangle inequality" in w for w in model.warnings)


def test_a_real_robot_every_body():
    from robots import erd
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))
    checks = dynamics.check_inertias(model)
    assert [c.body for c in checks] == list(model.body_names)
    for c, m, I in zip(checks, model.masses, model.inertias):
        assert c.mass == m
        np.testing.assert_allclose(c.principal_moments, np.linalg.eigvalsh(I), rtol=1e-12, atol=1e-16)
        assert c.verdict == "ok"
    with pytest.raises(dynamics.InputError, match="model"):
        dynamics.check_inertias("panda")
