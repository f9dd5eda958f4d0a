"""``dynamics simulate ROBOT --contact ground[:...]``: a ball of radius 0.1 m and 1 kg, dropped on a ground and on a
raised one; the resting height against the library's documented default material (a contact carrying the whole
weight sinks the penetration allowance: the centre rests at radius - allowance above the ground)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dynamics.cli import main

BALL = ('<robot name="ball"><link name="ball"><inertial><mass value="1"/><inertia ixx="0.004" iyy="0.004" '
        'izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial><collision><geometry><sphere radius="0.1"/></geometry>'
        '</collision></link></robot>')


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli-contact") / "ball.urdf"
    path.write_text(BALL)
    return str(path)


def run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("spec, ground", [("ground", 0.0), ("ground:mu=0.5,height=0.2,allowance=0.002", 0.2)])
def test_the_ball_comes_to_rest_on_the_ground(ball, tmp_path, capsys, spec, ground):
    out = tmp_path / "run.npz"
    code, text, err = run(capsys, "simulate", ball, "--floating-base", "--duration", "1", "--q0", "0,0,0.5,0,0,0,1",
                          "--contact", spec, "--rtol", "1e-9", "--atol", "1e-11", "--out", str(out))
    assert code == 0, err
    assert text.splitlines()[-1].startswith("contact: largest penetration")
    allowance = 0.002 if "allowance" in spec else 1e-3
    with np.load(out) as f:
        q, report = f["q"], json.loads(str(f["report"]))
    assert q[-1, 2] == pytest.approx(ground + 0.1 - allowance, abs=1e-8)
    assert report["contact"]["max_penetration"] >= allowance


def test_a_tilted_ground_and_no_contact(ball, capsys):
    """An incline of 30 degrees with mu = 0.8 > tan 30 deg: the ball may roll, never pass through; without
    --contact it falls through the ground."""
    normal = (np.sin(np.pi / 6), 0.0, np.cos(np.pi / 6))
    code, text, err = run(capsys, "simulate", ball, "--floating-base", "--duration", "0.3", "--q0", "0,0,0.2,0,0,0,1",
                          "--contact", "ground:mu=0.8,normal=%g,%g,%g" % normal, "--json")
    assert code == 0, err
    assert json.loads(text)["contact"]["time_in_contact"] > 0
    code, text, err = run(capsys, "simulate", ball, "--floating-base", "--duration", "0.3", "--q0", "0,0,0.2,0,0,0,1",
                          "--json")
    assert code == 0 and "contact" not in json.loads(text)


@pytest.mark.parametrize("spec, message", [("floor", "--contact: unknown kind 'floor'"),
                                           ("ground:mu=-1", "Material.mu_static"),
                                           ("ground:normal=0,0,0", "Ground.normal"),
                                           ("ground:bounce=1", "--contact: unknown key 'bounce'"),
                                           ("ground:mu=x", "--contact mu")])
def test_a_bad_contact_is_one_line_naming_it(ball, capsys, spec, message):
    code, text, err = run(capsys, "simulate", ball, "--floating-base", "--duration", "0.1", "--contact", spec)
    assert code == 1 and message in err and len(err.strip().splitlines()) == 1, err
