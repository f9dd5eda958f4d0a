"""Fuzzing with a bounded budget (issue 11 section 6): the URDF loader, the service's XML wall and its body codec.

Each raises only its documented errors on any input: ``dynamics.URDFError`` (a ValueError naming what was
wrong) for the loader, :class:`service.errors.Problem` (a 4xx) for the service. Anything else (a TypeError, an
IndexError, a MemoryError, a hang) fails. Inputs are mutations of valid documents, so that most of them get
deep into the parsers rather than failing at the first byte.
"""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import orjson
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dynamics
from robots import chain_urdf
from service import schemas
from service.catalog import check_xml
from service.codec import NPZ, decode, encode
from service.errors import Problem
from service.routes.dynamics import ROUTES

BUDGET = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                  suppress_health_check=list(HealthCheck))

BASE = chain_urdf(3)
ODD_VALUES = ["", "nan", "inf", "-inf", "1e300", "-1e-320", "0", "-1", "1 2", "1 2 3 4", "a b c", "1e300 1e300 1e300",
              "  ", "0x10", "1_000", "\u00e9", "9" * 400]


@st.composite
def mutated_urdf(draw) -> bytes:
    """A chain URDF with a few edits: attribute values replaced, spans cut, duplicated or swapped, bytes added."""
    text = BASE
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["value", "cut", "dup", "insert", "tag"]))
        n = len(text)
        i = draw(st.integers(0, n - 1))
        j = draw(st.integers(i, min(n, i + 200)))
        if kind == "value":
            start = text.find('="', i)
            if start >= 0:
                end = text.find('"', start + 2)
                text = text[:start + 2] + draw(st.sampled_from(ODD_VALUES)) + text[end:]
        elif kind == "cut":
            text = text[:i] + text[j:]
        elif kind == "dup":
            text = text[:j] + text[i:j] + text[j:]
        elif kind == "insert":
            text = text[:i] + draw(st.text(max_size=20)) + text[i:]
        else:
            text = text.replace(draw(st.sampled_from(["mass", "inertia", "joint", "link", "axis", "limit", "origin"])),
                                draw(st.sampled_from(["masss", "inertai", "joint", "robot", "", "link"])), 1)
    return text.encode("utf-8", "surrogatepass")


@BUDGET
@given(mutated_urdf(), st.booleans())
def test_urdf_loader_raises_only_urdf_errors(data, floating_base):
    try:
        model = dynamics.load_urdf(data, floating_base=floating_base)
    except dynamics.DynamicsError:
        return
    assert model.nv >= 0 and np.isfinite(model.inertias).all() if hasattr(model, "inertias") else True


@BUDGET
@given(mutated_urdf())
def test_service_xml_wall_raises_only_problems(data):
    try:
        check_xml(data, max_bytes=1 << 20, max_depth=16, max_links=64)
    except Problem:
        pass


def _json_values():
    scalars = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(allow_nan=True), st.text(max_size=8))
    return st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                         st.dictionaries(st.text(max_size=6), inner, max_size=4)),
                        max_leaves=20)


FIELDS = ["q", "v", "a", "tau", "f_ext", "gravity", "locked", "extra"]


@BUDGET
@given(st.dictionaries(st.sampled_from(FIELDS), _json_values(), max_size=5), st.sampled_from(sorted(ROUTES)))
def test_json_bodies_raise_only_problems(payload, route):
    body = json.dumps(payload).encode()
    try:
        schemas.validate(ROUTES[route][0], decode(body, "application/json", max_unpacked=1 << 20))
    except Problem:
        pass


@BUDGET
@given(st.binary(max_size=300), st.sampled_from(["application/json", NPZ, ";;;;", "text/plain", None]))
def test_raw_bodies_raise_only_problems(body, content_type):
    try:
        decode(body, content_type, max_unpacked=1 << 20)
    except Problem:
        pass


@st.composite
def npz_archive(draw) -> bytes:
    """A valid .npz of a few members, then possibly corrupted: a header edited, bytes cut or flipped."""
    buf = io.BytesIO()
    members = {name: np.zeros(draw(st.lists(st.integers(0, 4), max_size=3)),
                              dtype=draw(st.sampled_from(["f8", "i1", "u2", "c16", "U3", "b1", "V4"])))
               for name in draw(st.lists(st.sampled_from(["q", "v", "a", "locked"]), min_size=1, max_size=3))}
    (np.savez_compressed if draw(st.booleans()) else np.savez)(buf, **members)
    data = bytearray(buf.getvalue())
    for _ in range(draw(st.integers(0, 3))):
        i = draw(st.integers(0, len(data) - 1))
        if draw(st.booleans()):
            data[i] = draw(st.integers(0, 255))
        else:
            del data[i:i + draw(st.integers(1, 30))]
    return bytes(data)


@BUDGET
@given(npz_archive())
def test_npz_bodies_raise_only_problems(body):
    try:
        out = decode(body, NPZ, max_unpacked=1 << 20)
        for name in ("q", "v", "a"):
            if name in out:
                schemas.validate(schemas.InverseDynamicsRequest, {"q": out.get("q", 0), "v": out.get("v", 0),
                                                                  "a": out.get("a", 0)})
    except Problem:
        pass
    except zipfile.BadZipFile:  # pragma: no cover - reported as a failure below
        raise


@BUDGET
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=60), st.integers(1, 3))
def test_json_answers_round_trip_exactly(values, rows):
    arr = np.array(values * rows).reshape(rows, -1)
    back = orjson.loads(encode({"tau": arr, "report": {"n": np.int64(3)}}, None).body)
    assert np.array_equal(np.array(back["tau"]), arr) and back["report"] == {"n": 3}
