# SPDX-License-Identifier: MIT
"""BroadPhase margins and move_swept against a brute-force model: each
object's stored box derived by the documented rule (given box grown by the
margin; move_swept: union of the previous box, the last swept one given, and
the new one), every frame's pairs and boxes compared, 1 and 2 threads."""
import numpy as np
import pytest

import hybrid_broadphase as hbp

F = np.float32


def grown(b, m):
    return np.concatenate([b[:3] - F(m), b[3:] + F(m)]).astype(F)


def united(a, b):
    return np.concatenate([np.minimum(a[:3], b[:3]), np.maximum(a[3:], b[3:])]).astype(F)


def random_boxes(rng, n):
    lo = (rng.integers(0, 30, (n, 3)) * 0.5).astype(F)
    return np.hstack([lo, lo + (rng.integers(0, 5, (n, 3)) * 0.5).astype(F)])


@pytest.mark.parametrize("threads", [1, 2])
def test_margins_and_swept_moves_match_model(threads):
    rng = np.random.default_rng(20 + threads)
    bp = hbp.BroadPhase(threads=threads)
    obj = {}  # handle -> dict(stored, end, swept, static, margin)
    for frame in range(200):
        if len(obj) < 80 or rng.random() < 0.2:
            boxes = random_boxes(rng, int(rng.integers(1, 4)))
            static, m = bool(rng.random() < 0.25), float(rng.choice([0, 0, 0.25, 1.5]))
            for h, b in zip(bp.add(boxes, static=static, margin=m).tolist(), boxes):
                obj[h] = dict(stored=grown(b, m), end=None, swept=False, static=static, margin=m)
        live = sorted(obj)
        if rng.random() < 0.2:
            pick = sorted(set(rng.choice(live, size=min(8, len(live))).tolist()))
            m = float(rng.choice([0, 0.5]))
            bp.set_margin(pick, m)
            for h in pick:
                obj[h]["margin"] = m
        if rng.random() < 0.1:
            h = live[int(rng.integers(len(live)))]
            bp.remove([h])
            del obj[h]
        movers = [h for h in sorted(obj) if not obj[h]["static"] and rng.random() < 0.4]
        if movers:
            given = random_boxes(rng, len(movers))
            swept = bool(rng.random() < 0.5)
            (bp.move_swept if swept else bp.move)(movers, given)
            for h, b in zip(movers, given):
                o = obj[h]
                nb = grown(b, o["margin"])
                if swept:
                    o["stored"] = united(o["end"] if o["swept"] else o["stored"], nb)
                    o["end"], o["swept"] = nb, True
                else:
                    o["stored"], o["swept"] = nb, False
        hs = sorted(obj)
        boxes = np.array([obj[h]["stored"] for h in hs], F)
        st = np.array([obj[h]["static"] for h in hs])
        m = np.all(boxes[:, None, :3] <= boxes[None, :, 3:], axis=2) & np.all(boxes[None, :, :3] <= boxes[:, None, 3:], axis=2)
        m &= ~(st[:, None] & st[None, :])
        i, j = np.nonzero(np.triu(m, k=1))
        want = np.stack([np.array(hs)[i], np.array(hs)[j]], axis=1).astype(np.uint32).reshape(-1, 2)
        np.testing.assert_array_equal(bp.update().pairs, want)
        for h in hs[:10]:
            np.testing.assert_array_equal(bp.box(h), obj[h]["stored"])
            assert bp.margin(h) == obj[h]["margin"]


def test_margin_arguments():
    bp = hbp.BroadPhase()
    h = bp.add(np.array([[0, 0, 0, 1, 1, 1]], F), margin=0.5)
    assert bp.box(int(h[0])).tolist() == [-0.5, -0.5, -0.5, 1.5, 1.5, 1.5]
    bp.move_swept(h, np.array([[3, 0, 0, 4, 1, 1]], F))
    assert bp.box(int(h[0])).tolist() == [-0.5, -0.5, -0.5, 4.5, 1.5, 1.5]
    with pytest.raises(ValueError, match="margin"):
        bp.add(np.zeros((1, 6), F), margin=-1.0)
    with pytest.raises(ValueError, match="margin"):
        bp.set_margin(h, float("nan"))
    with pytest.raises(ValueError):
        bp.move_swept(h, np.zeros((2, 6), F))
