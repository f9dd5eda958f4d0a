"""Compiled models of the stored robots: built once, kept in a bounded cache, reduced on request.

A request names a robot and, optionally, joints to hold still (``locked``). :meth:`Models.loaded` returns the
model for that pair from the cache, or builds it: the full model from the URDF (``dynamics.load_urdf``), then
the reduced one (``dynamics.lock_joints``), each cached under ``(robot id, locked set)``. An unknown robot is a
:class:`~service.errors.NotFound`; a bad locked set is the library's InputError, which names the joint.
Used by the server threads and by the simulation workers alike (which see no store: :func:`load_model`).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, Callable, Hashable, Optional

from .errors import InvalidInput, NotFound, echo
from .library import lib
from .scene import ModelScene
from .store import RobotRecord, RobotStore


class ModelCache:
    """A bounded least-recently-used map of compiled models, shared by the threads of one process.

    Keys are ``(robot id, locked joints)``: ``()`` for the robot as uploaded, the canonical locked set of a
    request (:func:`locked_key`) for a reduced model, so each locked set is built once and evicted like any
    robot. Loading happens outside the lock: two threads missing the same key at once both load (harmless:
    models are immutable) rather than one waiting on the other's lock.
    """

    def __init__(self, size: int):
        self.size = max(1, int(size))
        self._items: OrderedDict[Hashable, Any] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get_or_load(self, key: Hashable, load: Callable[[], Any]) -> Any:
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                self.hits += 1
                return self._items[key]
            self.misses += 1
        value = load()
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > self.size:
                self._items.popitem(last=False)
        return value

    def peek(self, key: Hashable) -> Any:
        """The cached value or None, without loading and without touching the recency order."""
        with self._lock:
            return self._items.get(key)

    def discard(self, robot: str) -> None:
        with self._lock:
            for key in [k for k in self._items if k[0] == robot]:
                del self._items[key]

    def __len__(self) -> int:
        return len(self._items)


def locked_key(locked: Optional[dict[str, Any]]) -> tuple:
    """A request's ``locked`` -> the hashable, canonical part of a model cache key.

    Sorted by joint name, every value a tuple of floats, so that {"a": 1, "b": [2]} and {"b": 2.0, "a": 1.0}
    share one reduced model. ``+ 0.0`` turns -0.0 into 0.0 (the same pose).
    """
    if not locked:
        return ()
    return tuple(sorted((name, tuple(float(x) + 0.0 for x in (v if isinstance(v, (list, tuple)) else (v,))))
                        for name, v in locked.items()))


def load_model(urdf: str | bytes, floating_base: bool):
    """``dynamics.load_urdf`` on a document; a URDF the library refuses is an InvalidInput naming ``urdf``.

    Always bytes: the library reads a str that does not start with '<' as a file path, and no path named by a
    caller may ever be opened.
    """
    data = urdf.encode("utf-8") if isinstance(urdf, str) else urdf
    try:
        return lib().load_urdf(data, floating_base=floating_base)
    except ValueError as e:  # URDFError names the link or joint at fault
        message = str(e)
        raise InvalidInput(message if message.lower().startswith("urdf") else f"urdf: {message}", "urdf") from None


def collision_geometry(loaded: "Loaded") -> tuple:
    """The model's collision primitives (``model.collision_geometry``); for a model built without them, those of
    its URDF read again with ``collision=True`` (same document and options: the same bodies in the same order),
    for the inspector only, so that no other request pays for them."""
    own = getattr(loaded.model, "collision_geometry", ())
    if own or loaded.record is None:
        return tuple(own)
    data = loaded.record.urdf.encode("utf-8") if isinstance(loaded.record.urdf, str) else loaded.record.urdf
    try:
        return tuple(lib().load_urdf(data, floating_base=loaded.record.floating_base,
                                     collision=True).collision_geometry)
    except (TypeError, ValueError):  # a library without contact geometry, or a primitive it refuses: none drawn
        return ()


def reduce_model(model, locked: tuple):
    """``dynamics.lock_joints`` for a :func:`locked_key`; its InputError names the joint ("locked: no movable
    joint named 'x'; joints are [...]", "locked['j']: expected 1 finite number, got [1.0, 2.0]")."""
    return lib().lock_joints(model, {name: (v[0] if len(v) == 1 else list(v)) for name, v in locked})


def cached(cache: ModelCache, rid: str, locked: tuple, load: Callable[[], Any],
           reduce: Callable[[Any, tuple], Any] = reduce_model) -> Any:
    """The one rule of every process (server, simulation worker, job runner): robot ``rid``'s full model under
    ``(rid, ())``, built once by ``load()``; the model with ``locked`` held still under ``(rid, locked)``, built
    once by ``reduce(full, locked)`` (a cached reduced model is used even when the full one was evicted)."""
    def full() -> Any:
        return cache.get_or_load((rid, ()), load)

    if not locked:
        return full()
    return cache.get_or_load((rid, locked), lambda: reduce(full(), locked))


@dataclass(frozen=True)
class Loaded:
    """What the model cache holds: a model, the part of every answer's scene that depends only on it, and the
    stored record it was built from (a simulation job carries its URDF to the worker: read once, not per request)."""
    model: Any
    scene: ModelScene
    record: Optional[RobotRecord] = None

    @classmethod
    def of(cls, model, record: Optional[RobotRecord] = None) -> "Loaded":
        return cls(model, ModelScene.of(model), record)


class Models:
    """The store's robots as compiled models, through one bounded cache per process."""

    def __init__(self, store: RobotStore, cache_size: int):
        self.store = store
        self.cache = ModelCache(cache_size)

    def record(self, rid: str) -> RobotRecord:
        rec = self.store.get(rid)
        if rec is None:
            raise NotFound(f"robot: no robot with id {echo(rid)}", "robot")
        return rec

    def loaded(self, rid: str, locked: tuple = ()) -> Loaded:
        """Robot ``rid`` with the joints of ``locked`` (a :func:`locked_key`) held still: the full model from the
        cache or the URDF, then the reduced one from the cache or ``lock_joints``. May parse a URDF: call it
        from a worker thread."""
        # A robot deleted through another server process must not keep answering from this one's cache.
        if not self.store.exists(rid):
            self.cache.discard(rid)
            raise NotFound(f"robot: no robot with id {echo(rid)}", "robot")

        def load() -> Loaded:
            rec = self.record(rid)
            return Loaded.of(load_model(rec.urdf, rec.floating_base), rec)

        return cached(self.cache, rid, locked, load,
                      lambda full, lk: Loaded.of(reduce_model(full.model, lk), full.record))

    def is_cached(self, rid: str, locked: tuple) -> bool:
        return self.cache.peek((rid, locked)) is not None

    def keep(self, rid: str, model) -> None:
        """Cache a model just built from robot ``rid``'s URDF (an upload), so that no request builds it again."""
        self.cache.get_or_load((rid, ()), lambda: Loaded.of(model, self.store.get(rid)))

    def forget(self, rid: str) -> None:
        self.cache.discard(rid)
