# SPDX-License-Identifier: MIT
"""BroadPhase.raycast_closest and BroadPhase.box_cast against a float32
scan written here (the library's slab rule, operation for operation):
randomized add / move / remove / update sequences of static and moving
objects, 1 and 2 threads, and the argument errors."""
import numpy as np
import pytest

import hybrid_broadphase as hbp

F = np.float32


def slab_hits(lo, hi, origin, direction, max_t):
    """RaySegment::hits in float32 for every box (lo, hi: (n, 3)): (mask, entry t)."""
    t0 = np.zeros(len(lo), F)
    t1 = np.full(len(lo), max_t, F)
    ok = np.ones(len(lo), bool)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        for k in range(3):
            inv = F(1) / F(direction[k])
            if direction[k] == 0 or np.isinf(inv):
                ok &= (origin[k] >= lo[:, k]) & (origin[k] <= hi[:, k])
                continue
            a = (lo[:, k] - F(origin[k])) * inv
            b = (hi[:, k] - F(origin[k])) * inv
            t0 = np.maximum(t0, np.minimum(a, b))
            t1 = np.minimum(t1, np.maximum(a, b))
    ok &= t0 <= t1
    return ok, t0


def by_entry(handles, mask, t):
    hs, ts = handles[mask], t[mask]
    order = np.lexsort((hs, ts))  # by t, then handle
    return hs[order], ts[order]


def world_arrays(model):
    hs = np.array(sorted(model), np.uint32)
    boxes = np.array([model[h] for h in hs.tolist()], F).reshape(-1, 6)
    return hs, boxes


def random_boxes(rng, n):
    lo = rng.uniform(0, 20, (n, 3)).astype(F)
    snap = rng.random(n) < 0.5
    lo[snap] = np.round(lo[snap] * 2) / 2
    ext = rng.uniform(0, 3, (n, 3)).astype(F)
    ext[snap] = np.round(ext[snap] * 2) / 2
    return np.hstack([lo, lo + ext]).astype(F)


def random_vec(rng, scale):
    v = rng.uniform(-scale, scale, 3).astype(F)
    v[rng.random(3) < 0.3] = 0
    return v


@pytest.mark.parametrize("threads", [1, 2])
def test_closest_ray_and_box_cast_match_scan(threads):
    rng = np.random.default_rng(threads)
    bp = hbp.BroadPhase(threads=threads)
    model = {}
    moving = []
    for step in range(400):
        if len(model) < 200 or rng.random() < 0.2:
            boxes = random_boxes(rng, int(rng.integers(1, 5)))
            static = bool(rng.random() < 0.4)
            hs = bp.add(boxes, static=static)
            for h, b in zip(hs.tolist(), boxes):
                model[h] = b
                if not static:
                    moving.append(h)
        if moving and rng.random() < 0.2:
            h = moving.pop(int(rng.integers(len(moving))))
            bp.remove([h])
            del model[h]
        if moving:
            pick = sorted(set(rng.choice(moving, size=min(len(moving), 20)).tolist()))
            boxes = np.array([model[h] for h in pick], F)
            shift = rng.integers(-1, 2, (len(pick), 3)).astype(F) * F(0.5)
            boxes[:, :3] += shift
            boxes[:, 3:] += shift
            bp.move(pick, boxes)
            for h, b in zip(pick, boxes):
                model[h] = b
        if rng.random() < 0.5:
            bp.update()
        hs, boxes = world_arrays(model)
        lo, hi = boxes[:, :3], boxes[:, 3:]
        for _ in range(3):
            origin = rng.uniform(-2, 22, 3).astype(F)
            direction = random_vec(rng, 1)
            max_t = float(np.inf) if rng.random() < 0.2 else float(F(rng.uniform(0, 40)))
            want_h, want_t = by_entry(hs, *slab_hits(lo, hi, origin, direction, F(max_t)))
            got = bp.raycast_closest(origin, direction, max_t)
            if len(want_h) == 0:
                assert got is None
            else:
                assert got == (int(want_h[0]), float(want_t[0]))
                assert got[0] == int(bp.query_ray(origin, direction, max_t)[0])
            box = random_boxes(rng, 1)[0]
            d = random_vec(rng, 8)
            # The cast: each target grown by the box, against the segment from 0 along d.
            want_h, _ = by_entry(hs, *slab_hits(lo - box[3:], hi - box[:3], np.zeros(3, F), d, F(1)))
            got = bp.box_cast(box, d)
            assert got.dtype == np.uint32
            np.testing.assert_array_equal(got, want_h)
            np.testing.assert_array_equal(bp.box_cast(box.tolist(), [0, 0, 0]), bp.query_box(box))


def test_closest_and_cast_small_cases_and_errors():
    bp = hbp.BroadPhase()
    assert bp.raycast_closest([0, 0, 0], [1, 0, 0], float("inf")) is None
    assert len(bp.box_cast([0, 0, 0, 1, 1, 1], [1, 0, 0])) == 0
    h = int(bp.add(np.array([[2, 0, 0, 3, 1, 1]], F))[0])
    assert bp.raycast_closest([0, 0.5, 0.5], [1, 0, 0], 10) == (h, 2.0)
    assert bp.raycast_closest([2.5, 0.5, 0.5], [1, 0, 0], 0) == (h, 0.0)
    assert bp.box_cast([0, 0, 0, 1, 1, 1], [1, 0, 0]).tolist() == [h]
    assert bp.box_cast([0, 0, 0, 1, 1, 1], [0.99, 0, 0]).tolist() == []
    with pytest.raises(ValueError, match="max_t"):
        bp.raycast_closest([0, 0, 0], [1, 0, 0], -1)
    with pytest.raises(ValueError, match="origin"):
        bp.raycast_closest([0, float("nan"), 0], [1, 0, 0], 1)
    with pytest.raises(ValueError, match="direction"):
        bp.raycast_closest([0, 0, 0], [1, 0], 1)
    with pytest.raises(ValueError, match="box"):
        bp.box_cast([1, 0, 0, 0, 1, 1], [1, 0, 0])
    with pytest.raises(ValueError, match="displacement"):
        bp.box_cast([0, 0, 0, 1, 1, 1], [float("inf"), 0, 0])
