# SPDX-License-Identifier: MIT
"""BroadPhase object filters (category / mask / group), user data and query
filters against a brute-force model: randomized frames of adds with filters,
set_filter, set_user_data, moves, removes and layer-table changes, static and
moving objects, 1 and 2 threads; filtered queries against a scan."""
import numpy as np
import pytest

import hybrid_broadphase as hbp

ALL = 2**64 - 1


def should_collide(fa, fb):
    (ca, ma, ga), (cb, mb, gb) = fa, fb
    if ga == gb and ga != 0:
        return ga > 0
    return (ca & mb) != 0 and (cb & ma) != 0


def overlaps(a, b):
    return bool(np.all(a[:3] <= b[3:]) and np.all(b[:3] <= a[3:]))


def random_boxes(rng, n):
    lo = (rng.integers(0, 40, (n, 3)) * 0.5).astype(np.float32)
    return np.hstack([lo, lo + (rng.integers(0, 6, (n, 3)) * 0.5).astype(np.float32)])


def random_filter(rng):
    if rng.random() < 0.5:
        return (1, ALL, 0)
    return (1 << int(rng.integers(3)), ALL if rng.random() < 0.3 else int(rng.integers(8)), int(rng.integers(-2, 3)))


@pytest.mark.parametrize("threads", [1, 2])
def test_filtered_frames_and_queries_match_model(threads):
    rng = np.random.default_rng(10 + threads)
    bp = hbp.BroadPhase(threads=threads)
    obj = {}  # handle -> [box, static, layer, filter, user]
    collide = np.ones((3, 3), bool)
    previous = set()
    for frame in range(200):
        if len(obj) < 100 or rng.random() < 0.2:
            boxes = random_boxes(rng, int(rng.integers(1, 5)))
            static, layer = bool(rng.random() < 0.3), int(rng.integers(3))
            f, user = random_filter(rng), int(rng.integers(0, 2**63))
            hs = bp.add(boxes, static=static, layer=layer, category=f[0], mask=f[1], group=f[2], user_data=user)
            for h, b in zip(hs.tolist(), boxes):
                obj[h] = [b, static, layer, f, user]
        live = sorted(obj)
        r = rng.random()
        if r < 0.1:
            h = live[int(rng.integers(len(live)))]
            bp.remove([h])
            del obj[h]
        elif r < 0.3:
            pick = sorted(set(rng.choice(live, size=min(10, len(live))).tolist()))
            f = random_filter(rng)
            bp.set_filter(pick, category=f[0], mask=f[1], group=f[2])
            for h in pick:
                obj[h][3] = f
        elif r < 0.4:
            pick = sorted(set(rng.choice(live, size=min(10, len(live))).tolist()))
            vals = [int(v) for v in rng.integers(0, 2**63, len(pick))]
            bp.set_user_data(pick, vals)
            for h, v in zip(pick, vals):
                obj[h][4] = v
        elif r < 0.5:
            a, b, c = int(rng.integers(3)), int(rng.integers(3)), bool(rng.random() < 0.5)
            bp.set_collides(a, b, c)
            collide[a, b] = collide[b, a] = c
        movers = [h for h in sorted(obj) if not obj[h][1] and rng.random() < 0.3]
        if movers:
            boxes = np.array([obj[h][0] for h in movers], np.float32)
            shift = (rng.integers(-1, 2, (len(movers), 3)) * 0.5).astype(np.float32)
            boxes[:, :3] += shift
            boxes[:, 3:] += shift
            bp.move(movers, boxes)
            for h, b in zip(movers, boxes):
                obj[h][0] = b
        hs = sorted(obj)
        want = []
        for i, a in enumerate(hs):
            for b in hs[i + 1:]:
                A, B = obj[a], obj[b]
                if (A[1] and B[1]) or not overlaps(A[0], B[0]) or not collide[A[2], B[2]]:
                    continue
                if should_collide(A[3], B[3]):
                    want.append((a, b))
        res = bp.update()
        assert [tuple(p) for p in res.pairs.tolist()] == want
        now = set(want)
        assert [tuple(p) for p in res.created.tolist()] == sorted(now - previous)
        previous = now
        ud = bp.pair_user_data(res.created)
        assert ud.dtype == np.uint64 and ud.shape == (len(res.created), 2)
        for (a, b), (ua, ub) in zip(res.created.tolist(), ud.tolist()):
            assert (ua, ub) == (obj[a][4], obj[b][4])
        for h in hs[:20]:
            assert bp.user_data(h) == obj[h][4]
            assert bp.filter(h) == obj[h][3]
        # A filtered box query.
        box = random_boxes(rng, 1)[0]
        lm = ALL >> 32 if rng.random() < 0.5 else int(rng.integers(8))
        cm = ALL if rng.random() < 0.5 else int(rng.integers(8))
        wq = [h for h in hs if (lm >> obj[h][2]) & 1 and obj[h][3][0] & cm and overlaps(obj[h][0], box)]
        assert bp.query_box(box, layers_mask=lm, category_mask=cm).tolist() == wq
        first = bp.raycast_closest([box[0], box[1], -1.0], [0, 0, 1], 50.0, layers_mask=lm, category_mask=cm)
        hits = bp.query_ray([box[0], box[1], -1.0], [0, 0, 1], 50.0, layers_mask=lm, category_mask=cm)
        assert (first is None) == (len(hits) == 0)
        if first is not None:
            assert first[0] == int(hits[0])
            assert all(obj[int(h)][3][0] & cm and (lm >> obj[int(h)][2]) & 1 for h in hits)


def test_filter_arguments():
    bp = hbp.BroadPhase()
    h = bp.add(np.array([[0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1]], np.float32), group=-1, user_data=2**64 - 1)
    assert bp.filter(int(h[0])) == (1, ALL, -1)
    assert bp.user_data(int(h[1])) == 2**64 - 1
    assert len(bp.update().pairs) == 0  # same negative group
    bp.set_filter(h[:1])
    assert len(bp.update().pairs) == 1
    with pytest.raises(ValueError, match="category"):
        bp.add(np.zeros((1, 6), np.float32), category=-1)
    with pytest.raises(ValueError, match="group"):
        bp.set_filter(h, group=2**31)
    with pytest.raises(ValueError, match="values"):
        bp.set_user_data(h, [1])
    with pytest.raises(ValueError, match="layers_mask"):
        bp.query_box([0, 0, 0, 1, 1, 1], layers_mask=2**32)
