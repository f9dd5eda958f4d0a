"""What a user says about contact: :class:`Material` (the force law's knobs, :mod:`.forces`) and :class:`Contact`
(the world, the geometry, the materials, the outputs), checked when they are made.

Defaults (Drake's "penetration allowance" heuristic, MultibodyPlant::EstimatePointContactParameters, with the
model's total mass m where Drake takes its heaviest body's):

    k = m g / delta                  a single contact carrying the whole weight sinks delta (the allowance,
                                     default 1 mm); g = |gravity| (9.81 when gravity is zero)
    d = sqrt(delta / g) / delta      Hunt-Crossley dissipation (s/m) that damps the weight on one contact
                                     critically: time scale sqrt(m / k), so an impact slower than ~1/d m/s
                                     hardly bounces (restitution e ~ 1 - 2/3 d v, see the guide)

Each geometry left at the default gets (2k, d), so that two default geometries combine to (k, d); a pair
combines its geometries' materials as Drake does:

    k = k_a k_b / (k_a + k_b),   d = (k_b d_a + k_a d_b) / (k_a + k_b),   mu = 2 mu_a mu_b / (mu_a + mu_b)

(static and dynamic coefficients each), and takes the larger stiction velocity.  For comparison, MuJoCo's
soft contacts default to solref = (0.02 s, 1): a critically damped response with a 20 ms time constant, whatever
the mass; the allowance above gives sqrt(delta / g) = 10 ms at 1 mm.  Friction defaults to mu = 1 (MuJoCo's
sliding default too), stiction velocity 1 mm/s (Drake's default stiction tolerance).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .forces import K_DISS, K_MU_D, K_MU_S, K_STIFF, K_VS, NMAT

#: the defaults of :class:`Material` (documented in the guide)
PENETRATION_ALLOWANCE = 1e-3  # m
STICTION_VELOCITY = 1e-3  # m/s
MU = 1.0
#: contact outputs a run can keep per sample (:class:`Contact` ``outputs``)
CONTACT_OUTPUTS = ("contacts",)


def _positive(name, x, allow_none=False, allow_zero=False):
    if x is None and allow_none:
        return None
    ok = isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))
    if ok:
        x = float(x)
        ok = math.isfinite(x) and (x > 0 or (allow_zero and x == 0))
    if not ok:
        what = "a finite number >= 0" if allow_zero else "a finite number > 0"
        raise InputError(f"{name}: expected {what}{' or None' if allow_none else ''}, got {x!r}")
    return x


@dataclass(frozen=True)
class Material:
    """Contact material of a geometry (or of every geometry: ``Contact(friction=Material(...))``).

    stiffness: N/m of the linear spring (None: from the penetration allowance and the robot's weight, module
        docstring).  dissipation: Hunt-Crossley dissipation d in s/m, f_n = k x (1 + d xdot)_+ (None: critical
        damping at the allowance).  mu_static, mu_dynamic: Coulomb coefficients (mu_dynamic None: = mu_static;
        it must not exceed mu_static).  stiction_velocity: m/s, the slip speed at which friction reaches
        mu_static (below it friction is a steep viscous law, :mod:`dynamics.contact.forces`).
        penetration_allowance: m, the penetration of a contact carrying the whole weight, for the default
        stiffness and dissipation.
    """

    stiffness: float = None
    dissipation: float = None
    mu_static: float = MU
    mu_dynamic: float = None
    stiction_velocity: float = STICTION_VELOCITY
    penetration_allowance: float = PENETRATION_ALLOWANCE

    def __post_init__(self):
        put = object.__setattr__
        put(self, "stiffness", _positive("Material.stiffness", self.stiffness, allow_none=True))
        put(self, "dissipation", _positive("Material.dissipation", self.dissipation, allow_none=True,
                                           allow_zero=True))
        put(self, "mu_static", _positive("Material.mu_static", self.mu_static, allow_zero=True))
        mu_d = self.mu_static if self.mu_dynamic is None else self.mu_dynamic
        put(self, "mu_dynamic", _positive("Material.mu_dynamic", mu_d, allow_zero=True))
        if self.mu_dynamic > self.mu_static:
            raise InputError(f"Material.mu_dynamic: expected <= mu_static ({self.mu_static:g}), got "
                             f"{self.mu_dynamic:g}")
        put(self, "stiction_velocity", _positive("Material.stiction_velocity", self.stiction_velocity))
        put(self, "penetration_allowance", _positive("Material.penetration_allowance",
                                                     self.penetration_allowance))

    def defaults(self, mass, g):
        """(k, d) of one geometry with this material for a model of total ``mass`` under gravity ``g``: its own
        values, or the allowance's (module docstring: 2k per geometry, so that two defaults make k)."""
        delta = self.penetration_allowance
        k = self.stiffness if self.stiffness is not None else 2.0 * mass * g / delta
        d = self.dissipation if self.dissipation is not None else math.sqrt(delta / g) / delta
        return k, d


def _material(name, m):
    if isinstance(m, Material):
        return m
    if isinstance(m, (int, float, np.integer, np.floating)) and not isinstance(m, (bool, np.bool_)):
        mu = _positive(name, m, allow_zero=True)
        return Material(mu_static=mu, mu_dynamic=mu)
    raise InputError(f"{name}: expected a friction coefficient (a number >= 0) or a dynamics.Material, got "
                     f"{type(m).__name__}")


class _Default:
    def __repr__(self):
        return "Ground()"


_GROUND = _Default()


@dataclass(frozen=True, eq=False)
class Contact:
    """Contact for :func:`dynamics.simulate` and :func:`dynamics.contact_forces`.

    ground: a :class:`dynamics.Ground` (default: the plane z = 0 with normal +z) or None for no ground.
    friction: the default material of every geometry: a friction coefficient mu (static = dynamic) or a
        :class:`Material`.  objects: static world objects (``dynamics.HalfSpace``, a ``dynamics.Box`` on frame
        "world"); free bodies belong to the model (``dynamics.add_free_body``).
    geometries: the robot's contact geometry (None: ``model.collision_geometry``; or a list of
        ``dynamics.Sphere/Box/Capsule/Cylinder/ContactPoint`` declarations).
    materials: {geometry name: Material or mu} overriding ``friction`` for those geometries (names as
        :func:`dynamics.contact.scene.build_scene` gives them; the ground is "ground").
    pairs, self_collision, exclude: the candidate pairs (:func:`~dynamics.contact.scene.build_scene`).
    outputs: () or ("contacts",): keep every active contact per sample (``Trajectory.contacts``).
    """

    ground: object = _GROUND
    friction: object = MU
    objects: tuple = ()
    geometries: object = None
    materials: dict = field(default_factory=dict)
    pairs: object = None
    self_collision: bool = False
    exclude: tuple = ()
    outputs: tuple = ()

    def __post_init__(self):
        put = object.__setattr__
        from .geometry import PRIMITIVES, Ground, HalfSpace
        if self.ground is _GROUND:
            put(self, "ground", Ground())
        if self.ground is not None and not isinstance(self.ground, (Ground, HalfSpace)):
            raise InputError(f"ground: expected dynamics.Ground(normal=..., height=...) or None, got "
                             f"{type(self.ground).__name__}")
        put(self, "friction", _material("friction", self.friction))
        if not isinstance(self.materials, dict):
            raise InputError(f"materials: expected a dict {{geometry name: Material}}, got "
                             f"{type(self.materials).__name__}")
        put(self, "materials", {str(k): _material(f"materials[{k!r}]", m) for k, m in self.materials.items()})
        for name in ("objects", "exclude", "geometries", "pairs"):  # tuples: a Contact never changes once made
            x = getattr(self, name)
            if x is None and name in ("geometries", "pairs"):
                continue
            if isinstance(x, (str, bytes)) or not hasattr(x, "__iter__"):
                raise InputError(f"{name}: expected a list, got {type(x).__name__}")
            put(self, name, tuple(x))
        for k, obj in enumerate(self.objects):
            static = isinstance(obj, HalfSpace) or (isinstance(obj, PRIMITIVES) and obj.frame == "world")
            if not static:
                raise InputError(f"objects[{k}]: expected a static object (dynamics.HalfSpace, or a dynamics.Box "
                                 f"on frame 'world'), got {type(obj).__name__}"
                                 + (f" on frame {obj.frame!r}: a free body belongs to the model "
                                    "(dynamics.add_free_body), its geometry to geometries" if hasattr(obj, "frame")
                                    else ""))
        if not isinstance(self.self_collision, (bool, np.bool_)):
            raise InputError(f"self_collision: expected True or False, got {self.self_collision!r}")
        outputs = self.outputs
        if isinstance(outputs, str) or not hasattr(outputs, "__iter__") or not set(outputs) <= set(CONTACT_OUTPUTS):
            raise InputError(f"outputs: expected a subset of {CONTACT_OUTPUTS}, got {outputs!r}")
        put(self, "outputs", tuple(outputs))

    @property
    def world(self):
        """The world's geometry: the ground (if any), then the objects."""
        return ((self.ground,) if self.ground is not None else ()) + self.objects


def combine(kd_a, kd_b, m_a, m_b):
    """A pair's material row from its geometries' (k, d) and Materials (:mod:`.config`'s rules)."""
    (ka, da), (kb, db) = kd_a, kd_b
    row = np.zeros(NMAT)
    row[K_STIFF] = ka * kb / (ka + kb)
    row[K_DISS] = (kb * da + ka * db) / (ka + kb)
    row[K_MU_S] = _harmonic(m_a.mu_static, m_b.mu_static)
    row[K_MU_D] = _harmonic(m_a.mu_dynamic, m_b.mu_dynamic)
    row[K_VS] = max(m_a.stiction_velocity, m_b.stiction_velocity)
    return row


def _harmonic(a, b):
    return 2 * a * b / (a + b) if a + b > 0 else 0.0
