"""Rigid-body dynamics for robots described by URDF.

    >>> import numpy as np, dynamics
    >>> model = dynamics.load_urdf("planar_2r")          # a bundled robot, or a path to a URDF file
    >>> q, v, a = model.neutral(), np.zeros(model.nv), np.ones(model.nv)
    >>> tau = dynamics.inverse_dynamics(model, q, v, a)  # M(q) a + C(q, v) v + g(q)

The public interface is the names below, ``dynamics.torques``, ``dynamics.plot`` and ``dynamics.robots``;
the modules under them are internal.
"""

from .errors import DeadlineExceeded, DynamicsError, InputError, SimulationWarning, URDFError
from .model import Model
from .urdf import load_urdf
from .rnea import bias_forces, gravity_torques, inverse_dynamics
from .crba import mass_matrix
from .aba import forward_dynamics
from .energy import kinetic_energy, potential_energy
from .coriolis import coriolis_matrix
from .reduce import lock_joints
from .inertia_check import InertiaCheck, check_inertias
from .reorder import reorder
from .kinematics import (forward_kinematics, frame_acceleration, frame_bias_acceleration, frame_placement,
                         frame_velocity)
from .jacobians import frame_jacobian
from .com import center_of_mass, center_of_mass_velocity, com_jacobian
from .minverse import inverse_mass_matrix
from .task_space import operational_space_inertia
from .inverse_kinematics import inverse_kinematics
from .constraints import (JointCoupling, PointConstraint, RevoluteConstraint, WeldConstraint, constraint_bias,
                          constraint_jacobian, constraint_residual, with_constraints)
from .constrained_dynamics import constrained_forward_dynamics, constrained_inverse_dynamics, project_velocity
from .assemble import assemble
from .rnea_derivatives import inverse_dynamics_derivatives
from .aba_derivatives import forward_dynamics_derivatives
from .constrained_derivatives import constrained_forward_dynamics_derivatives
from .kinematics_derivatives import (center_of_mass_derivatives, frame_acceleration_derivatives,
                                     frame_jacobian_time_variation, frame_velocity_derivatives)
from .configuration_jacobians import difference_jacobians, integrate_jacobians
from .torque_derivatives import closed_loop_derivatives, torque_source_derivatives
from .contact.geometry import (Box, Capsule, CollisionGeometry, ContactPoint, Cylinder, Ground, HalfSpace,
                               Sphere)
from .contact.free_bodies import add_free_body
from .contact.config import Contact, Material
from .contact.evaluation import contact_forces

from . import plot, robots, torques
from .configuration import difference, integrate
from .simulation import Simulator, Trajectory, simulate
from .simulation.work_precision import WorkPrecision, work_precision
from .sweeps import Trajectories, map_batches, simulate_many

__all__ = [
    "DeadlineExceeded", "DynamicsError", "InputError", "SimulationWarning", "URDFError", "Model", "load_urdf",
    "inverse_dynamics", "gravity_torques", "bias_forces", "mass_matrix", "forward_dynamics",
    "kinetic_energy", "potential_energy", "coriolis_matrix", "lock_joints", "reorder",
    "check_inertias", "InertiaCheck",
    "simulate", "Simulator", "Trajectory", "integrate", "difference", "torques", "robots", "plot",
    "simulate_many", "Trajectories", "map_batches", "work_precision", "WorkPrecision",
    "forward_kinematics", "frame_placement", "frame_velocity", "frame_acceleration", "frame_bias_acceleration",
    "frame_jacobian", "center_of_mass", "center_of_mass_velocity", "com_jacobian",
    "inverse_mass_matrix", "operational_space_inertia", "inverse_kinematics",
    "PointConstraint", "WeldConstraint", "RevoluteConstraint", "JointCoupling", "with_constraints",
    "constraint_residual", "constraint_jacobian", "constraint_bias", "constrained_forward_dynamics",
    "constrained_inverse_dynamics", "project_velocity", "assemble",
    "inverse_dynamics_derivatives", "forward_dynamics_derivatives", "constrained_forward_dynamics_derivatives",
    "frame_velocity_derivatives",
    "frame_acceleration_derivatives", "frame_jacobian_time_variation", "center_of_mass_derivatives",
    "integrate_jacobians", "difference_jacobians", "torque_source_derivatives", "closed_loop_derivatives",
    "CollisionGeometry", "Sphere", "Box", "Capsule", "Cylinder", "ContactPoint", "Ground", "HalfSpace",
    "add_free_body", "Contact", "Material", "contact_forces",
]
