# SPDX-License-Identifier: MIT
"""Where one box or one point is expected (query_box, query_ray), lists and
tuples of numbers are accepted, rounded to the nearest float32, with the
same results as float32 arrays and against a brute-force scan."""
import numpy as np
import pytest

import hybrid_broadphase as hbp
from hbp_reference import ray_entry


@pytest.fixture
def world():
    rng = np.random.default_rng(5)
    lo = rng.uniform(0, 20, (300, 3)).astype(np.float32)
    boxes = np.hstack([lo, lo + rng.uniform(0.1, 2, (300, 3)).astype(np.float32)]).astype(np.float32)
    bp = hbp.BroadPhase()
    handles = bp.add(boxes)
    bp.update()
    return bp, boxes, handles


def brute_box(boxes, handles, q):
    q = np.asarray(q, np.float32)
    hit = np.all(boxes[:, :3] <= q[3:], axis=1) & np.all(boxes[:, 3:] >= q[:3], axis=1)
    return sorted(handles[hit].tolist())


def test_box_as_list_or_tuple(world):
    bp, boxes, handles = world
    rng = np.random.default_rng(6)
    total = 0
    for _ in range(50):
        lo = rng.uniform(0, 20, 3)
        q = [float(v) for v in lo] + [float(v) for v in lo + rng.uniform(0.5, 4, 3)]
        want = brute_box(boxes, handles, q)
        as_array = bp.query_box(np.array(q, np.float32)).tolist()
        assert as_array == want
        assert bp.query_box(q).tolist() == want
        assert bp.query_box(tuple(q)).tolist() == want
        total += len(want)
    assert total > 50
    # Integers, and a tuple of numpy scalars.
    assert bp.query_box([0, 0, 0, 30, 30, 30]).tolist() == sorted(handles.tolist())
    assert bp.query_box(tuple(np.float64(v) for v in (0, 0, 0, 30, 30, 30))).tolist() == sorted(handles.tolist())


def test_rounding_keeps_touching_boxes():
    bp = hbp.BroadPhase()
    edge = np.float32(0.1)  # 0.100000001490116...
    (h,) = bp.add(np.array([[0, 0, 0, edge, 1, 1]], np.float32))
    # The exact query starts at 0.1 < float32(0.1): the boxes overlap, and so
    # they do after rounding to the nearest float32.
    assert bp.query_box([0.1, 0, 0, 1, 1, 1]).tolist() == [h]
    assert bp.query_box([0.10000001, 0, 0, 1, 1, 1]).tolist() == []  # past the edge by more than rounding


def test_ray_as_lists_and_tuples(world):
    bp, boxes, handles = world
    rng = np.random.default_rng(7)
    nonempty = 0
    for _ in range(50):
        o = rng.uniform(-2, 22, 3).astype(np.float32)
        d = rng.uniform(-1, 1, 3).astype(np.float32)
        want = bp.query_ray(o, d, 30.0).tolist()
        assert set(want) == set(handles[np.isfinite(ray_entry(boxes, o, d, 30.0))].tolist())
        assert bp.query_ray(o.tolist(), d.tolist(), 30.0).tolist() == want
        assert bp.query_ray(tuple(o.tolist()), tuple(d.tolist()), 30.0).tolist() == want
        nonempty += bool(want)
    assert nonempty > 10
    # Along x through the first box's centre: it is among the hits.
    c = (boxes[0, :3] + boxes[0, 3:]) / 2
    hits = bp.query_ray([-5.0, float(c[1]), float(c[2])], (1, 0, 0), float("inf")).tolist()
    assert int(handles[0]) in hits


@pytest.mark.parametrize("box,message", [
    ([0, 0, 0, 1, 1], r"box: shape must be \(6,\).*got \(5,\)"),
    ([[0, 0, 0, 1, 1, 1]], r"box: shape must be \(6,\).*got \(1, 6\)"),
    (["a", 0, 0, 1, 1, 1], "box: a list or tuple must hold numbers only"),
    ([0, float("nan"), 0, 1, 1, 1], "box: NaN coordinate on axis y"),
    ((2, 0, 0, 1, 1, 1), "box: min > max on axis x"),
])
def test_bad_box_sequences(world, box, message):
    bp = world[0]
    with pytest.raises(ValueError, match=message):
        bp.query_box(box)


@pytest.mark.parametrize("origin,message", [
    ([0, 0], r"origin: shape must be \(3,\), got \(2,\)"),
    ([0, None, 0], "origin: coordinate y is nan"),
    ((0, 0, float("inf")), "origin: coordinate z is inf"),
    ([0, "x", 0], "origin: a list or tuple must hold numbers only"),
])
def test_bad_point_sequences(world, origin, message):
    bp = world[0]
    with pytest.raises(ValueError, match=message):
        bp.query_ray(origin, [1, 0, 0], 1.0)


def test_many_boxes_still_need_an_array(world):
    bp, boxes, _ = world
    with pytest.raises(ValueError, match="boxes: dtype must be float32"):
        bp.add(boxes.tolist())
    with pytest.raises(ValueError, match=r"one box: a list of one row"):
        bp.add(np.zeros(6, np.float32))
