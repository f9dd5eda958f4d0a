"""The ``scene`` of every answer: what the model that answered left out, and which terms were not computed.

    "scene": {"locked": {"joint2": 0.3}, "links_pruned": ["imu_link"], "fixed_joints_merged": ["imu_joint", ...],
              "skipped": ["velocity products", "joint accelerations"], "nq": 5, "nv": 5}

The model's part (locked, pruned, merged, sizes) is computed once per cached model (:class:`ModelScene`); the
request's part (``skipped``) from which of v, a and gravity are zero, in the library's words
(``dynamics.rnea.skipped_terms``). ``links_pruned`` and ``fixed_joints_merged`` are named and valued as in the
library's ``Model.summary()`` (and so in robot info's ``summary``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from .library import lib

#: where an operation's v and a come from: "state" (the request's array), "zero" (held at zero: gravity torques,
#: bias forces) or "computed" (ABA's answer is a)
Terms = dict[str, str]


@dataclass(frozen=True)
class ModelScene:
    locked: dict[str, Any]
    links_pruned: list[str]
    fixed_joints_merged: list[str]
    nq: int
    nv: int

    @classmethod
    def of(cls, model) -> "ModelScene":
        info = model.summary()
        return cls(info.get("locked_joints", {}), list(info.get("links_pruned", [])),
                   list(info.get("fixed_joints_merged", ())), int(model.nq), int(model.nv))

    def answer(self, skipped: tuple[str, ...]) -> dict[str, Any]:
        return {"locked": self.locked, "links_pruned": self.links_pruned,
                "fixed_joints_merged": self.fixed_joints_merged, "skipped": list(skipped), "nq": self.nq, "nv": self.nv}


@functools.lru_cache(maxsize=None)
def terms_skipped(with_v: bool, with_a: bool, with_gravity: bool) -> tuple[str, ...]:
    """The library's names of the terms it leaves out, asked once per case: its np.any calls cost ~12 us, a
    third of a whole single-state request answered on the event loop."""
    return tuple(lib().rnea.skipped_terms(v=float(with_v), a=float(with_a), gravity=(float(with_gravity), 0, 0)))


def skipped(terms: Optional[Terms], args: dict[str, Any], model_gravity: np.ndarray) -> tuple[str, ...]:
    """Terms a request does not compute, for any state of its batch. ``terms`` None: the operation has none of
    them (the mass matrix), so nothing is reported skipped."""
    if terms is None:
        return ()
    present = [_nonzero(args[x]) if terms[x] == "state" else terms[x] == "computed" for x in "va"]
    g = args.get("gravity")
    return terms_skipped(present[0], present[1], _nonzero(model_gravity if g is None else g))


def simulation_scene(scene: ModelScene, model_gravity: np.ndarray, gravity: Optional[np.ndarray]) -> dict[str, Any]:
    """The scene of a simulation: velocities and accelerations evolve, so only gravity can be left out."""
    return scene.answer(terms_skipped(True, True, _nonzero(model_gravity if gravity is None else gravity)))


def _nonzero(x: Any) -> bool:
    return bool(x.any()) if isinstance(x, np.ndarray) else bool(np.any(x))
