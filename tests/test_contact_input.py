"""Bad input on every entry point of contact (Contact, Material, simulate's contact, contact_forces): a clear
InputError naming the field."""

import numpy as np
import pytest

import dynamics

BALL = """<robot name="ball"><link name="ball"><inertial><mass value="1"/>
<inertia ixx="0.004" iyy="0.004" izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""


@pytest.fixture(scope="module")
def ball():
    return dynamics.load_urdf(BALL, floating_base=True)


@pytest.mark.parametrize("kwargs, field", [
    (dict(friction=-1.0), "friction"), (dict(friction="rubber"), "friction"), (dict(friction=float("inf")), "friction"),
    (dict(materials=[("ball", 0.5)]), "materials"), (dict(materials={"ball": -0.5}), r"materials\['ball'\]"),
    (dict(materials={"ball": "steel"}), r"materials\['ball'\]"), (dict(outputs="contacts"), "outputs"),
    (dict(outputs=("forces",)), "outputs"), (dict(objects=5), "objects"), (dict(exclude="ball"), "exclude"),
    (dict(self_collision="yes"), "self_collision"), (dict(ground="floor"), "ground"),
    (dict(objects=[dynamics.Sphere("ball", 0.1)]), r"objects\[0\].*add_free_body"),
])
def test_contact_refuses(kwargs, field):
    with pytest.raises(dynamics.InputError, match=field):
        dynamics.Contact(**kwargs)


def test_simulate_refuses_bad_contact(ball):
    q0, v0 = np.array([0, 0, 0.5, 0, 0, 0, 1.0]), np.zeros(6)
    with pytest.raises(dynamics.InputError, match="contact: expected dynamics.Contact"):
        dynamics.simulate(ball, q0, v0, 0.1, contact="ground")
    with pytest.raises(dynamics.InputError, match="materials: no geometry named 'bal'.*'ball/sphere0'"):
        dynamics.simulate(ball, q0, v0, 0.1, contact=dynamics.Contact(geometries=[dynamics.Sphere("ball", 0.1)],
                                                                       materials={"bal": 0.3}))
    with pytest.raises(dynamics.InputError, match="frame"):
        dynamics.simulate(ball, q0, v0, 0.1, contact=dynamics.Contact(geometries=[dynamics.Sphere("foot", 0.1)]))


def test_contact_forces_refuses(ball):
    c = dynamics.Contact(geometries=[dynamics.Sphere("ball", 0.1)])
    q, v = np.array([0, 0, 0.05, 0, 0, 0, 1.0]), np.zeros(6)
    with pytest.raises(dynamics.InputError, match="contact: expected"):
        dynamics.contact_forces(ball, None, q, v)
    with pytest.raises(dynamics.InputError, match="q"):
        dynamics.contact_forces(ball, c, q[:6], v)
    with pytest.raises(dynamics.InputError, match="q"):
        dynamics.contact_forces(ball, c, np.array([q, q]), v)
    with pytest.raises(dynamics.InputError, match="v"):
        dynamics.contact_forces(ball, c, q, np.full(6, np.nan))
    with pytest.raises(dynamics.InputError, match="model"):
        dynamics.contact_forces("ball", c, q, v)
    f_ext = dynamics.contact_forces(ball, c, q, v)  # and a good call: the ball 5 cm deep carries k x
    assert f_ext.shape == (1, 6) and f_ext[0, 2] == pytest.approx(9.81 / 1e-3 * 0.05)
