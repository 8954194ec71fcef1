# SPDX-License-Identifier: MIT
"""Large worlds: BroadPhase(double_precision=True) against a float64 brute
force at 1e6 .. 1e9 (touching faces and sub-float gaps included), and
shift_origin on float32 and float64 worlds."""
import numpy as np
import pytest

import hybrid_broadphase as hb


def brute(boxes, is_static):
    """Sorted (k, 2) index pairs whose closed boxes overlap, not both static."""
    lo, hi = boxes[:, :3], boxes[:, 3:]
    ov = np.all((hi[:, None, :] >= lo[None, :, :]) & (lo[:, None, :] <= hi[None, :, :]), axis=2)
    ov &= ~(is_static[:, None] & is_static[None, :])
    i, j = np.nonzero(np.triu(ov, 1))
    return np.stack([i, j], axis=1).astype(np.uint32)


def as_set(pairs):
    return {tuple(p) for p in np.asarray(pairs).tolist()}


def random_boxes(rng, n, centre, spread=25.0):
    lo = centre + rng.uniform(-spread, spread, size=(n, 3))
    side = np.where(rng.random((n, 3)) < 0.25, rng.uniform(0.01, 0.1, (n, 3)), rng.uniform(0.01, 10.0, (n, 3)))
    return np.hstack([lo, lo + side])


@pytest.mark.parametrize("scale", [1e6, 1e7, 1e8, 1e9])
@pytest.mark.parametrize("threads", [1, 2])
def test_double_precision_matches_brute_force(scale, threads):
    rng = np.random.default_rng(int(scale) % 1000 + threads)
    n, n_static = 150, 40
    boxes = random_boxes(rng, n, np.array([scale, -scale, scale / 2]))
    is_static = np.arange(n) < n_static
    bp = hb.BroadPhase(threads=threads, double_precision=True)
    assert bp.double_precision
    h = np.concatenate([bp.add(boxes[:n_static], static=True), bp.add(boxes[n_static:])])
    assert (h == np.arange(n)).all()
    previous = set()
    touching = merged = 0
    for step in range(1000):
        rows = rng.choice(np.arange(n), size=10, replace=False)
        new = boxes[rows].copy()
        for r in range(len(rows)):
            if r % 3 == 0:  # against another box: exactly touching, or a sub-float gap away
                other = boxes[rng.integers(n)]
                gap = 0.0 if rng.random() < 0.5 else 2.0 ** -20 * max(1.0, scale / 1e6)
                side = new[r, 3:] - new[r, :3]
                k = rng.integers(3)
                new[r, :3] = other[:3]
                new[r, k] = other[3 + k] + gap
                new[r, 3:] = new[r, :3] + side
                touching += gap == 0.0
                merged += gap != 0.0
            else:
                new[r] += np.tile(rng.uniform(-0.5, 0.5, 3), 2)
        boxes[rows] = new
        bp.move(h[rows], new)
        pairs, created, removed = bp.update()
        want = brute(boxes, is_static)
        assert np.array_equal(pairs, want), step
        now = as_set(want)
        assert as_set(created) == now - previous
        assert as_set(removed) == previous - now
        previous = now
    assert touching > 100 and merged > 100 and len(previous) > 10
    got = bp.box(h[3])
    assert got.dtype == np.float64 and np.array_equal(got, boxes[3])
    q = boxes[7] + np.array([-1, -1, -1, 1, 1, 1.0])
    want_q = [i for i in range(n) if np.all(boxes[i, 3:] >= q[:3]) and np.all(boxes[i, :3] <= q[3:])]
    assert bp.query_box(q).tolist() == want_q
    offsets, hits = bp.query_boxes(q[None, :])
    assert hits.tolist() == want_q and offsets.tolist() == [0, len(want_q)]


def test_sub_float_gap_is_kept_apart():
    bp = hb.BroadPhase(double_precision=True)
    a = np.array([[1e7 + 0.25, 0, 0, 1e7 + 1.3, 1, 1]])
    b = np.array([[1e7 + 1.3 + 1e-6, 0, 0, 1e7 + 2.7, 1, 1]])
    c = np.array([[1e7 + 1.3, 0, 0, 1e7 + 2.7, 1, 1]])  # touches a exactly
    ha, hb_, hc = bp.add(a)[0], bp.add(b)[0], bp.add(c)[0]
    pairs = bp.update().pairs
    assert pairs.tolist() == [[ha, hc], [hb_, hc]]
    # float32 arrays on a double BroadPhase are widened exactly
    h32 = bp.add(np.array([[0, 0, 0, 1, 1, 1]], np.float32))
    assert bp.box(h32[0]).dtype == np.float64


def test_shift_origin_float_world():
    rng = np.random.default_rng(3)
    n = 200
    lo = rng.uniform(472, 552, size=(n, 3)).astype(np.float32)
    boxes = np.hstack([lo, lo + rng.uniform(0.01, 10, size=(n, 3)).astype(np.float32)]).astype(np.float32)
    is_static = np.arange(n) < 50
    bp = hb.BroadPhase(threads=2)
    bp.add(boxes[:50], static=True)
    h = bp.add(boxes[50:])
    before = bp.update().pairs
    assert np.array_equal(before, brute(boxes, is_static))
    # x - 512 is exact for x in [256, 1024]: no events.
    bp.shift_origin((512, 512, 512))
    boxes = boxes - np.float32(512)
    u = bp.update()
    assert np.array_equal(u.pairs, before) and len(u.created) == 0 and len(u.removed) == 0
    assert np.array_equal(bp.box(h[0]), boxes[50])
    # A rounding shift: pairs follow the float32-rounded boxes.
    bp.shift_origin([0.1, -1e6, 0.3])
    boxes = boxes - np.array([0.1, -1e6, 0.3, 0.1, -1e6, 0.3], np.float32)
    assert np.array_equal(bp.update().pairs, brute(boxes, is_static))
    assert np.array_equal(bp.box(h[5]), boxes[55])


def test_shift_origin_double_world():
    rng = np.random.default_rng(4)
    boxes = random_boxes(rng, 120, np.array([1e9, 1e9, 1e9]))
    bp = hb.BroadPhase(double_precision=True)
    h = bp.add(boxes)
    before = bp.update().pairs
    bp.shift_origin([2.0 ** 30] * 3)  # exact in float64 near 1e9
    u = bp.update()
    assert np.array_equal(u.pairs, before) and len(u.created) == 0
    assert np.array_equal(bp.box(h[0]), boxes[0] - 2.0 ** 30)


def test_invalid_inputs():
    f = hb.BroadPhase()
    d = hb.BroadPhase(double_precision=True)
    # float64 boxes on a float BroadPhase keep today's rule: ValueError
    with pytest.raises(ValueError, match="float32"):
        f.add(np.zeros((1, 6)))
    with pytest.raises(ValueError, match="float64"):
        d.add(np.zeros((1, 6), np.int32))
    with pytest.raises(ValueError, match="row 1"):
        d.add(np.array([[0, 0, 0, 1, 1, 1], [0, 0, 0, np.nan, 1, 1]]))
    with pytest.raises(ValueError, match="min > max"):
        d.add(np.array([[2, 0, 0, 1, 1, 1.0]]))
    assert len(d) == 0
    h = d.add(np.array([[0, 0, 0, 1, 1, 1.0]]))
    for bp in (f, d):
        with pytest.raises(ValueError):
            bp.shift_origin([0, np.nan, 0])
        with pytest.raises(ValueError):
            bp.shift_origin([np.inf, 0, 0])
        with pytest.raises(ValueError):
            bp.shift_origin([1, 2])
    d.add(np.array([[1e308, 0, 0, 1.5e308, 1, 1]]))
    with pytest.raises(ValueError, match="finite range"):
        d.shift_origin([-1.7e308, 0, 0])  # 1.5e308 + 1.7e308 overflows: nothing applied
    assert d.box(h[0]).tolist() == [0, 0, 0, 1, 1, 1]
    with pytest.raises(ValueError, match="equal"):
        d.move(h, np.zeros((2, 6)))
