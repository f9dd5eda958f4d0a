"""The contacts a simulation keeps per sample (``Contact(outputs=("contacts",))``): a fixed capacity per sample,
K = the scene's ``max_contacts`` (every candidate pair's most contacts at once, :mod:`.scene`), so that no
contact is ever dropped; ``count[j]`` says how many of sample j's K rows are in use (the rest are zero, pair -1).

:class:`ContactSamples` (T samples, world frame; geometry a is the pair's first, the normal points from b to a):

============  ============  ==========================================================================
field         shape         meaning
============  ============  ==========================================================================
count         (T,) int64    active contacts at sample j
pair          (T, K) int64  index into ``pairs`` (-1: unused row)
point         (T, K, 3)     contact point (m)
normal        (T, K, 3)     unit normal, from geometry b towards a
normal_force  (T, K)        f_n >= 0 (N): the force on a is f_n normal + friction
friction      (T, K, 3)     friction force on a (N), tangent to the contact
depth         (T, K)        penetration (m) > 0
slip          (T, K, 3)     tangential velocity of a relative to b at the point (m/s)
pairs         list          (name of geometry a, name of geometry b) per candidate pair
============  ============  ==========================================================================

``simulate_many`` stacks the runs' samples (:func:`stack`): every field but ``pairs`` gains a leading run axis
(B, T, ...); a run's samples after its last (it stopped early, or raised) have count 0, pair -1 and NaN values.
"""

from typing import NamedTuple

import numpy as np


class ContactSamples(NamedTuple):
    """The active contacts per sample (module docstring)."""

    count: np.ndarray
    pair: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    normal_force: np.ndarray
    friction: np.ndarray
    depth: np.ndarray
    slip: np.ndarray
    pairs: list


def contact_samples(resolved, c, cnt):
    """The :class:`ContactSamples` of the first cnt samples a run's contact ``c`` (a PackedContact) kept, or None
    when the contact did not ask for them."""
    if "contacts" not in resolved.contact.outputs:
        return None
    cm = c
    out, n = cm.out[:cnt], cm.out_n[:cnt].copy()
    K = out.shape[1]
    used = np.arange(K)[None, :] < n[:, None]
    pair = np.where(used, out[:, :, 0].astype(np.int64), -1)
    scene = resolved.scene
    names = [(scene.names[a], scene.names[b]) for a, b in zip(scene.pair_a, scene.pair_b)]
    return ContactSamples(n, pair, out[:, :, 1:4].copy(), out[:, :, 4:7].copy(), out[:, :, 7].copy(),
                          out[:, :, 8:11].copy(), out[:, :, 11].copy(), out[:, :, 12:15].copy(), names)


def stack(samples, T):
    """One :class:`ContactSamples` for B runs' (``samples``: a ContactSamples or None per run, each of at most T
    samples), or None when no run kept contacts."""
    first = next((s for s in samples if s is not None), None)
    if first is None:
        return None
    B, K = len(samples), first.pair.shape[1]
    out = ContactSamples(np.zeros((B, T), np.int64), np.full((B, T, K), -1, np.int64),
                         *(np.full((B, T, K) + f.shape[2:], np.nan) for f in first[2:8]), first.pairs)
    for k, s in enumerate(samples):
        if s is None:
            continue
        n = s.count.shape[0]
        for dst, src in zip(out[:8], s[:8]):
            dst[k, :n] = src
    return out
