# SPDX-License-Identifier: MIT
"""Brute-force numpy references for the hybrid_broadphase tests: every pair
of boxes, box queries and ray queries, and a model of BroadPhase's state
(handles -> box, static, layer; the layer table; the pair filter)."""
import numpy as np

EMPTY_PAIRS = np.zeros((0, 2), np.uint32)


def overlap_matrix(a, b):
    """(len(a), len(b)) bool: closed boxes overlap (touching faces count)."""
    return np.all((a[:, None, 3:] >= b[None, :, :3]) & (a[:, None, :3] <= b[None, :, 3:]), axis=2)


def brute_pairs(boxes):
    """Every overlapping pair (i < j) of rows, (k, 2) uint32 sorted."""
    n = len(boxes)
    if n < 2:
        return EMPTY_PAIRS.copy()
    m = np.triu(overlap_matrix(boxes, boxes), k=1)
    i, j = np.nonzero(m)  # row-major: sorted by (i, j)
    return np.stack([i, j], axis=1).astype(np.uint32)


def ray_entry(boxes, origin, direction, max_t):
    """Entry t of the segment origin + t * direction, 0 <= t <= max_t, into
    each box (float64; inf when missed)."""
    o = origin.astype(np.float64)
    d = direction.astype(np.float64)
    lo = boxes[:, :3].astype(np.float64)
    hi = boxes[:, 3:].astype(np.float64)
    t0 = np.zeros(len(boxes))
    t1 = np.full(len(boxes), float(max_t))
    for k in range(3):
        if d[k] == 0:
            inside = (o[k] >= lo[:, k]) & (o[k] <= hi[:, k])
            t1 = np.where(inside, t1, -np.inf)
        else:
            a = (lo[:, k] - o[k]) / d[k]
            b = (hi[:, k] - o[k]) / d[k]
            t0 = np.maximum(t0, np.minimum(a, b))
            t1 = np.minimum(t1, np.maximum(a, b))
    return np.where(t0 <= t1, t0, np.inf)


class Model:
    """What a BroadPhase should hold and report, computed by brute force."""

    def __init__(self):
        self.boxes = {}  # handle -> (6,) float32
        self.static = {}
        self.layer = {}
        self.collide = np.ones((32, 32), bool)
        self.filter = None
        self.pairs = EMPTY_PAIRS.copy()

    def add(self, handles, boxes, static, layer):
        for h, b in zip(handles.tolist(), boxes):
            assert h not in self.boxes, f"handle {h} handed out twice"
            self.boxes[h] = b.copy()
            self.static[h] = static
            self.layer[h] = layer

    def move(self, handles, boxes):
        for h, b in zip(handles.tolist(), boxes):
            self.boxes[h] = b.copy()

    def remove(self, handles):
        for h in handles.tolist():
            del self.boxes[h], self.static[h], self.layer[h]

    def set_collides(self, a, b, c):
        self.collide[a, b] = self.collide[b, a] = c

    def frame_pairs(self):
        hs = np.array(sorted(self.boxes), np.uint32)
        if len(hs) < 2:
            return EMPTY_PAIRS.copy()
        boxes = np.array([self.boxes[h] for h in hs.tolist()], np.float32)
        st = np.array([self.static[h] for h in hs.tolist()])
        ly = np.array([self.layer[h] for h in hs.tolist()])
        m = overlap_matrix(boxes, boxes)
        m &= ~(st[:, None] & st[None, :])
        m &= self.collide[ly[:, None], ly[None, :]]
        i, j = np.nonzero(np.triu(m, k=1))
        pairs = np.stack([hs[i], hs[j]], axis=1).astype(np.uint32)  # hs sorted: a < b, (a, b) order
        if self.filter is not None and len(pairs):
            keep = np.array([bool(self.filter(int(a), int(b))) for a, b in pairs], bool)
            pairs = pairs[keep]
        return pairs

    def update(self):
        """(pairs, created, removed) of the next update."""
        now = self.frame_pairs()
        before = set(map(tuple, self.pairs.tolist()))
        after = set(map(tuple, now.tolist()))
        created = np.array(sorted(after - before), np.uint32).reshape(-1, 2)
        removed = np.array(sorted(before - after), np.uint32).reshape(-1, 2)
        self.pairs = now
        return now, created, removed

    def query_box(self, box):
        hs = np.array(sorted(self.boxes), np.uint32)
        if len(hs) == 0:
            return hs
        boxes = np.array([self.boxes[h] for h in hs.tolist()], np.float32)
        return hs[overlap_matrix(boxes, box[None, :])[:, 0]]
