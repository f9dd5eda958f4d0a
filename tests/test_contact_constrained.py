"""Closed loops keep working with contact (issue 19, section 2): the four-bar linkage (a <loop> constraint,
the KKT right-hand side) whose rocker tip strikes the ground.  The constraints hold, the energy balance with the
contact's work closes, and the simulated accelerations are the constrained dynamics with contact_forces as f_ext."""

import os

import numpy as np
import pytest

import dynamics
from robots import OUR_ROBOTS

TAU = np.array([0.3, 0.0, 0.0])


@pytest.mark.slow  # its own solver compilation (constrained problem with contact) and 2000 KKT solves: ~100 CPU s cold
def test_four_bar_striking_the_ground():
    model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "four_bar.urdf"))
    q0 = dynamics.assemble(model, np.array([0.2, 0.5, 1.5]), fixed=["theta1"])
    v0 = dynamics.project_velocity(model, q0, np.array([4.0, 0, 0]))
    # the rocker's tip swings down to z = 0.187 m: a ground at 0.2 m stops it
    contact = dynamics.Contact(ground=dynamics.Ground(height=0.2), geometries=[dynamics.ContactPoint("link3", (0.3, 0, 0))],
                               friction=dynamics.Material(stiffness=2e4, dissipation=1.0, mu_static=0.0),
                               outputs=("contacts",))
    traj = dynamics.simulate(model, q0, v0, 2.0, torque=TAU, integrator="rk45", rtol=1e-8, atol=1e-10,
                             contact=contact, sample_dt=1e-3, error_estimate="none")
    rep = traj.report
    assert rep["status"] == "ok"
    assert rep["constraint_drift"]["position"] < 1e-8 and rep["constraint_drift"]["velocity"] < 1e-6
    c = rep["contact"]
    assert c["time_in_contact"] > 0.5 and 0 < c["max_penetration"] < 0.05
    assert c["energy_dissipated"] > 0.1 and rep["energy_drift"] < 1e-7  # the work of the contact forces included
    tips = traj.contacts.point[traj.contacts.count > 0, 0]
    assert np.all(tips[:, 2] < 0.2)  # the point midway between the tip and the ground, below the ground
    acc = np.array([dynamics.forward_dynamics(model, q, v, TAU, f_ext=dynamics.contact_forces(model, contact, q, v))
                    for q, v in zip(traj.q, traj.v)])
    h = traj.t[1] - traj.t[0]
    fd = (traj.v[2:] - traj.v[:-2]) / (2 * h)
    n = traj.contacts.count
    steady = (n[:-2] == n[1:-1]) & (n[1:-1] == n[2:])  # central differences do not straddle a touch-down
    assert np.abs(fd - acc[1:-1])[steady].max() < 2e-3 * np.abs(acc).max()
