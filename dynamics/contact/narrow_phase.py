"""Narrow phase: the contacts of every candidate pair of a :class:`~dynamics.contact.scene.Scene` at one
configuration, in the C++ core (``core/contact/narrow_phase.cpp``, allocation-free); this module is its Python
face (:func:`find_contacts`, :func:`scene_poses`) and its documentation.

Given the world pose (oR_i, op_i) of each body, geometry g of body b sits at

    oR_g = oR_b R_g,    op_g = oR_b p_g + op_b        (R_g, p_g as stored for body -1: already in the world).

For each pair (a, b) (ordered so that kind[a] <= kind[b]) the core first runs the broad phase -- bounding spheres
|op_a - op_b| < r_a + r_b, and for a plane (half-space n . x <= h) the test n . op_a - h < r_a -- then the pair's
function from the table below, which writes each penetrating contact into the run's buffer:

* ``point``: the world point midway between the two surfaces (the deepest point of each),
* ``normal``: the world unit normal pointing from geometry b towards geometry a (the direction that pushes a
  out of b),
* ``depth``: the penetration along it, > 0 (touching or separated pairs write nothing).

=================  ==========================================================================  ========
pair               method                                                                      contacts
=================  ==========================================================================  ========
sphere - plane     centre's signed distance minus r (a point is a sphere of radius 0)          1
capsule - plane    its two end spheres                                                         2
cylinder - plane   the deepest rim point of each cap and two more on the lower cap at +-120 deg  4
box - plane        each of the 8 vertices below the plane                                      8
sphere - sphere    centres' distance                                                           1
sphere - capsule   sphere against the closest point of the segment                             1
capsule - capsule  closest points of the segments; parallel overlapping segments: both ends     2
                   of the overlap
sphere - box       closest point of the box (inside: the nearest face)                         1
capsule - box      both end spheres when both penetrate, else the deepest point of the         2
                   segment (golden-section search of the box's signed distance, convex)
box - box          separating axis test over 15 axes; a face axis: the incident face clipped   8
                   against the reference face's sides (Sutherland-Hodgman), its points below
                   the reference face; an edge-edge axis: the closest points of the two edges
=================  ==========================================================================  ========

Once a capsule's axis enters a box the depth is that of the axis's deepest point (plus r), not the least
translation out.  A cylinder against a sphere, capsule or box is the capsule of the same radius and length
(its flat ends rounded: contact starts up to r early beyond each end); against a plane it is exact.
"""

from typing import NamedTuple

import numpy as np

from .. import _core, checks
from ..errors import InputError

#: separating-axis test: an edge-edge axis is taken only when its overlap is below this fraction of the best
#: face axis's (faces give a manifold; edges, nearly parallel to a face, a single point); the core's constant
EDGE_BIAS = 0.95


# -- from Python -----------------------------------------------------------------------------------------

class Contacts(NamedTuple):
    """The penetrating contacts of a scene at one configuration (n of them), from :func:`find_contacts`."""

    a: tuple  # (n,) name of geometry a of each contact (scene.names)
    b: tuple  # (n,) name of geometry b (the normal points from b towards a)
    pair: np.ndarray  # (n,) index of the pair in scene.pair_a / pair_b
    point: np.ndarray  # (n, 3) world point midway between the surfaces
    normal: np.ndarray  # (n, 3) world unit normal from b towards a
    depth: np.ndarray  # (n,) penetration (m), > 0


def _checked_configuration(model, scene, q):
    """q checked against ``model`` and ``scene`` against its bodies: the one configuration, a float64 copy."""
    Q, batched = checks.configurations(model, q)
    if batched:
        raise InputError(f"q: expected one configuration of shape ({model.nq},), got {np.shape(q)}")
    if scene.body.shape[0] and int(scene.body.max()) >= model.nbodies:
        raise InputError(f"scene: built for a model with more bodies than {model.name!r} has ({model.nbodies})")
    return np.ascontiguousarray(Q[0], dtype=np.float64).copy()


def scene_poses(model, scene, q) -> np.ndarray:
    """(ng, 4, 4) world pose of every geometry of ``scene`` at ``q`` (to draw it; a plane's z axis is its
    normal and its origin the point of the plane nearest the world origin)."""
    q = _checked_configuration(model, scene, q)
    return _core.scene_poses(model.core, scene.body, scene.R, scene.p, q)


def find_contacts(model, scene, q) -> Contacts:
    """The contacts of ``scene`` (built for ``model`` by :func:`~dynamics.contact.scene.build_scene`) at the
    configuration ``q``: the broad and narrow phase of the C++ core (core/contact/narrow_phase.cpp), the one the
    simulation runs at each right-hand side."""
    q = _checked_configuration(model, scene, q)
    k, point, normal, depth = _core.find_contacts(model.core, *scene.arrays, q, scene.max_contacts)
    return Contacts(tuple(scene.names[scene.pair_a[i]] for i in k), tuple(scene.names[scene.pair_b[i]] for i in k),
                    k, point, normal, depth)
