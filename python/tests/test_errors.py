# SPDX-License-Identifier: MIT
"""Every bad input raises ValueError naming the argument, row or handle, and
changes nothing (the next update reports the state from before the call)."""
import numpy as np
import pytest

import hybrid_broadphase as hbp

GOOD = np.array([[0, 0, 0, 1, 1, 1], [0.5, 0.5, 0.5, 2, 2, 2], [5, 5, 5, 6, 6, 6], [1, 1, 1, 3, 3, 3]], np.float32)


def bad_rows(row, values):
    b = GOOD.copy()
    b[row] = values
    return b


NAN_ROW2 = bad_rows(2, [5, np.nan, 5, 6, 6, 6])
INF_ROW3 = bad_rows(3, [1, 1, 1, 3, np.inf, 3])
INVERTED_ROW1 = bad_rows(1, [0.5, 0.5, 3, 2, 2, 2])

BAD_BOXES = [
    (GOOD.astype(np.float64), "dtype must be float32, got float64"),
    (GOOD.astype(np.int32), "dtype must be float32"),
    (GOOD.astype(np.float16), "dtype must be float32"),
    (GOOD.astype(">f4"), "dtype must be float32"),
    (GOOD.tolist(), "dtype must be float32"),
    (GOOD[:, :5], r"shape must be \(n, 6\).*got \(4, 5\)"),
    (GOOD[0], r"shape must be \(n, 6\).*got \(6,\)"),
    (GOOD[None], r"shape must be \(n, 6\).*got \(1, 4, 6\)"),
    (None, "got None"),
    (NAN_ROW2, "row 2: NaN coordinate on axis y"),
    (INF_ROW3, "row 3: infinite coordinate on axis y"),
    (INVERTED_ROW1, "row 1: min > max on axis z"),
]


@pytest.mark.parametrize("boxes,message", BAD_BOXES)
def test_find_pairs_rejects(boxes, message):
    with pytest.raises(ValueError, match=message):
        hbp.find_pairs(boxes)


@pytest.mark.parametrize("kw,message", [
    ({"engine": "nope"}, "unknown engine 'nope'"),
    ({"threads": -1}, "threads"),
    ({"cell_limit": 1}, "cell_limit"),
    ({"max_pairs": -5}, "max_pairs"),
])
def test_bad_options(kw, message):
    with pytest.raises(ValueError, match=message):
        hbp.find_pairs(GOOD, **kw)
    with pytest.raises(ValueError, match=message):
        hbp.BroadPhase(**kw)


@pytest.fixture
def world():
    """A BroadPhase with 4 objects, one update done, and one removed handle."""
    bp = hbp.BroadPhase()
    h = bp.add(GOOD)
    stale = bp.add(GOOD[:1])
    bp.remove(stale)
    r = bp.update()
    return bp, h, int(stale[0]), r.pairs.copy()


def assert_unchanged(bp, h, pairs):
    """Nothing applied: same objects, same boxes, no events at the next update."""
    assert len(bp) == len(h)
    for i, x in enumerate(h):
        np.testing.assert_array_equal(bp.box(x), GOOD[i])
        assert bp.layer(x) == 0 and not bp.is_static(x)
    assert all(bp.collides(a, b) for a in range(32) for b in range(32))
    r = bp.update()
    np.testing.assert_array_equal(r.pairs, pairs)
    assert len(r.created) == 0 and len(r.removed) == 0


@pytest.mark.parametrize("boxes,message", BAD_BOXES)
def test_add_rejects_bad_boxes(world, boxes, message):
    bp, h, _, pairs = world
    with pytest.raises(ValueError, match=message):
        bp.add(boxes)
    assert_unchanged(bp, h, pairs)


@pytest.mark.parametrize("layer", [-1, 32, 1000])
def test_add_rejects_bad_layer(world, layer):
    bp, h, _, pairs = world
    with pytest.raises(ValueError, match=f"layer: {layer} is out of range"):
        bp.add(GOOD, layer=layer)
    assert_unchanged(bp, h, pairs)


@pytest.mark.parametrize("boxes,message", BAD_BOXES)
def test_move_rejects_bad_boxes(world, boxes, message):
    bp, h, _, pairs = world
    with pytest.raises(ValueError, match=message):
        bp.move(h, boxes)
    assert_unchanged(bp, h, pairs)


def test_move_rejects_bad_handles(world):
    bp, h, stale, pairs = world
    moved = GOOD + np.float32(10)
    cases = [
        (np.array([h[0], h[1], stale, h[3]], np.uint32), f"handles row 2: handle {stale} is unknown or stale"),
        (np.array([h[0], h[1], h[2], 12345], np.uint32), "handles row 3: handle 12345 is unknown or stale"),
        (np.array([h[0], h[1], h[0], h[3]], np.uint32), f"row 2: handle {h[0]} .*row 0"),
        (h.astype(np.float32), "dtype must be an integer type"),
        (h.astype(bool), "dtype must be an integer type"),
        (h.reshape(2, 2), r"shape must be \(n,\)"),
        (np.array([h[0], h[1], -1, h[3]]), "handles row 2: -1 is not a handle"),
        (np.array([h[0], h[1], 2**40, h[3]], np.int64), "handles row 2: 1099511627776 is not a handle"),
        (h[:3], "3 handles but 4 boxes"),
    ]
    for handles, message in cases:
        with pytest.raises(ValueError, match=message):
            bp.move(handles, moved)
    assert_unchanged(bp, h, pairs)


def test_remove_rejects_bad_handles(world):
    bp, h, stale, pairs = world
    for handles, message in [
        (np.array([h[0], stale], np.uint32), f"handles row 1: handle {stale} is unknown or stale"),
        (np.array([h[1], h[2], h[1]], np.uint32), f"row 2: handle {h[1]} .*row 0"),
        ([h[0], 1.5], "dtype must be an integer type"),
        (np.uint32(h[0]), r"shape must be \(n,\)"),
    ]:
        with pytest.raises(ValueError, match=message):
            bp.remove(handles)
    assert_unchanged(bp, h, pairs)


def test_python_int_lists_are_handles(world):
    bp, h, _, _ = world
    bp.remove([int(h[3])])  # int64 input, converted after a range check
    assert len(bp) == 3 and h[3] not in bp


def test_layer_and_table_errors(world):
    bp, h, stale, pairs = world
    with pytest.raises(ValueError, match="layer_a: 32 is out of range"):
        bp.set_collides(32, 0, False)
    with pytest.raises(ValueError, match="layer_b: -1 is out of range"):
        bp.set_collides(0, -1, False)
    with pytest.raises(ValueError, match="layer_a: expected an integer, got float"):
        bp.set_collides(1.0, 0, False)
    with pytest.raises(ValueError, match="layer: 40 is out of range"):
        bp.set_layer(h, 40)
    with pytest.raises(ValueError, match=f"handles row 1: handle {stale} is unknown or stale"):
        bp.set_layer(np.array([h[0], stale], np.uint32), 3)
    assert_unchanged(bp, h, pairs)


def test_accessors_reject_stale_handles(world):
    bp, h, stale, pairs = world
    for f in (bp.box, bp.layer, bp.is_static):
        with pytest.raises(ValueError, match=f"handle: handle {stale} is unknown or stale"):
            f(stale)
        with pytest.raises(ValueError, match="not a handle"):
            f(-3)
    assert not bp.contains(stale)
    assert_unchanged(bp, h, pairs)


def test_query_errors(world):
    bp, h, _, pairs = world
    o = np.zeros(3, np.float32)
    d = np.ones(3, np.float32)
    for box, message in [
        (GOOD[0].astype(np.float64), "box: dtype must be float32"),
        (GOOD[:1], r"box: shape must be \(6,\)"),
        (np.array([0, 0, 0, 1, np.nan, 1], np.float32), "box: NaN coordinate on axis y"),
        (np.array([2, 0, 0, 1, 1, 1], np.float32), "box: min > max on axis x"),
    ]:
        with pytest.raises(ValueError, match=message):
            bp.query_box(box)
    with pytest.raises(ValueError, match="boxes row 2: NaN coordinate"):
        bp.query_boxes(NAN_ROW2)
    for args, message in [
        ((o.astype(np.float64), d, 1.0), "origin: dtype must be float32"),
        ((o[:2], d, 1.0), r"origin: shape must be \(3,\)"),
        ((o, np.array([0, np.nan, 0], np.float32), 1.0), "direction: coordinate y is nan"),
        ((o, np.array([0, 0, np.inf], np.float32), 1.0), "direction: coordinate z is inf"),
        ((o, d, -1.0), "max_t: must be >= 0"),
        ((o, d, float("nan")), "max_t: must be >= 0"),
    ]:
        with pytest.raises(ValueError, match=message):
            bp.query_ray(*args)
    assert_unchanged(bp, h, pairs)


@pytest.mark.parametrize("objects", [-1, 2**24, 2**40])
def test_reserve_rejects_bad_counts(world, objects):
    bp, h, _, pairs = world
    with pytest.raises(ValueError, match=f"reserve: objects must be 0..16777215, got {objects}"):
        bp.reserve(objects)
    assert_unchanged(bp, h, pairs)
