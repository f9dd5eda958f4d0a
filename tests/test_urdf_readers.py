"""Our <inertial> and <joint> readers (dynamics.urdf.read_inertial / read_joint, which let `import dynamics`
skip yourdfpy, trimesh and scipy.spatial) read every example-robot-data URDF to the same bits as yourdfpy's
URDF._parse_inertial / _parse_joint, which the loader used before, and so build bit-identical models."""

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
from yourdfpy import URDF

import dynamics
from dynamics import URDFError, urdf
from tests.robots import erd, erd_urdfs


def same_bits(a, b, where="model"):
    """a and b equal down to the bits of every float (signs of zero and NaN payloads included)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), where
    elif dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            same_bits(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            same_bits(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            same_bits(x, y, f"{where}[{k}]")
    elif isinstance(a, float):
        assert type(b) is float and np.float64(a).tobytes() == np.float64(b).tobytes(), where
    else:
        assert a == b, where


def test_readers_match_yourdfpy_on_every_example_robot_data_urdf():
    n_links = n_joints = 0
    for path in erd_urdfs():
        with open(erd(path), "rb") as fh:
            root = urdf.parse_xml(fh.read())
        for el in root.findall("link"):
            ours, theirs = urdf.read_inertial(el.find("inertial")), URDF._parse_inertial(el.find("inertial"))
            if theirs is None:
                assert ours is None
                continue
            for f in ("origin", "mass", "inertia"):
                same_bits(getattr(ours, f), getattr(theirs, f), f"{path} link {el.get('name')} {f}")
            n_links += 1
        for el in root.findall("joint"):
            ours, theirs = urdf.read_joint(el), URDF._parse_joint(el)
            where = f"{path} joint {ours.name}"
            for f in ("name", "type", "parent", "child", "origin", "axis"):
                same_bits(getattr(ours, f), getattr(theirs, f), f"{where} {f}")
            for part, fields in (("limit", ("lower", "upper", "effort", "velocity")),
                                 ("dynamics", ("damping", "friction")), ("mimic", ("joint", "multiplier", "offset"))):
                a, b = getattr(ours, part), getattr(theirs, part)
                assert (a is None) == (b is None), f"{where} {part}"
                for f in fields if a is not None else ():
                    same_bits(getattr(a, f), getattr(b, f), f"{where} {part}.{f}")
            n_joints += 1
    assert n_links > 500 and n_joints > 500  # the whole collection was read, not a stray file


def test_models_are_bit_identical_to_the_yourdfpy_based_loader(monkeypatch):
    paths = [erd(p) for p in erd_urdfs()]
    ours = {}
    for p in paths:
        try:
            ours[p] = dynamics.load_urdf(p, strict_inertia=False)
        except URDFError as e:
            ours[p] = str(e)
    monkeypatch.setattr(urdf, "read_inertial", URDF._parse_inertial)
    monkeypatch.setattr(urdf, "read_joint", URDF._parse_joint)
    loaded = 0
    for p in paths:
        try:
            theirs = dynamics.load_urdf(p, strict_inertia=False)
        except URDFError as e:
            theirs = str(e)
        if isinstance(theirs, str):
            assert ours[p] == theirs, p
            continue
        same_bits(ours[p], theirs, p)
        loaded += 1
    assert loaded > 30


@pytest.mark.parametrize("extra, expected", [
    ('<origin xyz="0 0"/>', "joint 'j': cannot read it (origin xyz: expected 3 numbers, got 2)"),
    ('<origin rpy="0 0 0 1"/>', "joint 'j': cannot read it (origin rpy: expected 3 numbers, got 4)"),
    ('<origin xyz="0 0 abc"/>', "joint 'j': cannot read it (could not convert string to float: 'abc')"),
    ('<limit lower="x" upper="1"/>', "joint 'j': cannot read it (could not convert string to float: 'x')"),
    ('<mimic joint="j" multiplier="two"/>', "joint 'j': cannot read it (could not convert string to float: 'two')"),
    ('<calibration rising="up"/>', "joint 'j': cannot read it (could not convert string to float: 'up')"),
    ('<axis xyz="0 1"/>', "joint 'j': axis must have 3 numbers, got 2"),
])
def test_malformed_joint_numbers_name_the_joint(extra, expected):
    text = ('<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/>'
            '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
            f'<joint name="j" type="revolute"><parent link="a"/><child link="b"/>{extra}</joint></robot>')
    with pytest.raises(URDFError) as err:
        dynamics.load_urdf(text)
    assert str(err.value) == expected


def test_defaults_follow_yourdfpy():
    root = urdf.parse_xml(b'<robot name="r"><joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
                          b'<axis/><limit effort="3"/><dynamics/><mimic joint="k"/></joint></robot>')
    j = urdf.read_joint(root.find("joint"))
    assert j.origin is None
    np.testing.assert_array_equal(j.axis, [1.0, 0.0, 0.0])
    assert j.limit == urdf.Limit(lower=None, upper=None, effort=3.0, velocity=None)
    assert j.dynamics == urdf.JointDynamics(None, None)
    assert j.mimic == urdf.Mimic("k", 1.0, 0.0)


def test_import_dynamics_skips_yourdfpy_trimesh_and_scipy_spatial():
    code = "import sys, dynamics; print(sorted(m for m in ('yourdfpy', 'trimesh', 'scipy.spatial') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
