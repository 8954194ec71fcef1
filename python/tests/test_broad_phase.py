# SPDX-License-Identifier: MIT
"""BroadPhase against the brute-force model, frame by frame: randomized
sequences of batched add / move / remove with layers, static and moving
objects, layer-table and filter changes; queries; determinism."""
import numpy as np
import pytest

import hybrid_broadphase as hbp
from hbp_reference import Model, ray_entry


def random_boxes(rng, n, extent=40.0, size=5.0):
    lo = rng.uniform(0, extent, (n, 3)).astype(np.float32)
    # Integer-aligned boxes now and then: touching faces between objects.
    snap = rng.random(n) < 0.3
    lo[snap] = np.round(lo[snap])
    ext = rng.uniform(0.5, size, (n, 3)).astype(np.float32)
    ext[snap] = np.round(ext[snap]) + 1
    return np.hstack([lo, lo + ext]).astype(np.float32)


def assert_update(bp, model):
    r = bp.update()
    pairs, created, removed = model.update()
    for name, got, want in (("pairs", r.pairs, pairs), ("created", r.created, created), ("removed", r.removed, removed)):
        assert got.dtype == np.uint32 and got.shape[1:] == (2,), name
        np.testing.assert_array_equal(got, want, err_msg=name)
    return r


def check_queries(bp, model, rng):
    """A box query, a batch of them and a ray, against the model: queries see
    every edit so far (and must not change what the next update reports)."""
    q = random_boxes(rng, 3, size=12.0)
    np.testing.assert_array_equal(bp.query_box(q[0]), model.query_box(q[0]))
    offsets, hits = bp.query_boxes(q[1:])
    for i in range(2):
        np.testing.assert_array_equal(hits[offsets[i]:offsets[i + 1]], model.query_box(q[1 + i]))
    if model.boxes:
        hs = np.array(sorted(model.boxes), np.uint32)
        boxes = np.array([model.boxes[h] for h in hs.tolist()], np.float32)
        origin = rng.uniform(0, 40, 3).astype(np.float32)
        direction = rng.normal(0, 1, 3).astype(np.float32)
        t = ray_entry(boxes, origin, direction, 60.0)
        assert set(bp.query_ray(origin, direction, 60.0).tolist()) == set(hs[np.isfinite(t)].tolist())


def run_sequence(seed, threads, frames=25, queries=False):
    rng = np.random.default_rng(seed)
    bp = hbp.BroadPhase(engine="sw", threads=threads)
    model = Model()
    events = []
    # A static world on layers 0 and 1, moving objects on layers 0..3.
    for static, layer, n in ((True, 0, 150), (True, 1, 60), (False, 0, 80), (False, 2, 40), (False, 3, 30)):
        boxes = random_boxes(rng, n)
        h = bp.add(boxes, static=static, layer=layer)
        assert h.dtype == np.uint32 and h.shape == (n,)
        model.add(h, boxes, static, layer)
    bp.set_collides(2, 3, False)
    model.set_collides(2, 3, False)
    r = assert_update(bp, model)
    assert len(r.pairs) > 100
    for frame in range(frames):
        live = np.array(sorted(model.boxes), np.uint32)
        moving = np.array([h for h in live.tolist() if not model.static[h]], np.uint32)
        # Move: most moving objects drift, some teleport; now and then a static one moves.
        sel = rng.choice(moving, size=min(len(moving), int(rng.integers(10, 60))), replace=False).astype(np.uint32)
        new = np.array([model.boxes[h] for h in sel.tolist()], np.float32)
        drift = rng.normal(0, 0.8, (len(sel), 3)).astype(np.float32)
        new[:, :3] += drift
        new[:, 3:] += drift
        teleport = rng.random(len(sel)) < 0.1
        new[teleport] = random_boxes(rng, int(teleport.sum()))
        if frame % 5 == 2:
            statics = np.array([h for h in live.tolist() if model.static[h]], np.uint32)
            s = rng.choice(statics, size=3, replace=False).astype(np.uint32)
            sel = np.concatenate([sel, s])
            new = np.vstack([new, random_boxes(rng, 3)])
        bp.move(sel, new)
        model.move(sel, new)
        if queries:
            check_queries(bp, model, rng)
        # Remove a batch (moving and static), add a batch (slots get reused).
        gone = rng.choice(live, size=int(rng.integers(0, 12)), replace=False).astype(np.uint32)
        gone = np.setdiff1d(gone, sel).astype(np.uint32)
        bp.remove(gone)
        model.remove(gone)
        if queries:
            check_queries(bp, model, rng)
        for h in gone.tolist():
            assert h not in bp
        static = bool(rng.random() < 0.3)
        layer = int(rng.integers(0, 4))
        boxes = random_boxes(rng, int(rng.integers(0, 15)))
        h = bp.add(boxes, static=static, layer=layer)
        model.add(h, boxes, static, layer)
        if queries:
            check_queries(bp, model, rng)
        assert not set(h.tolist()) & set(gone.tolist()), "a removed handle came back unchanged"
        if frame % 7 == 3:  # layer table and layer changes
            a, b = (int(x) for x in rng.integers(0, 4, 2))
            c = bool(rng.random() < 0.5)
            bp.set_collides(a, b, c)
            model.set_collides(a, b, c)
            assert bp.collides(a, b) == c and bp.collides(b, a) == c
        if frame % 6 == 4:
            who = rng.choice(moving, size=5, replace=False).astype(np.uint32)
            who = np.setdiff1d(who, gone).astype(np.uint32)
            layer = int(rng.integers(0, 4))
            bp.set_layer(who, layer)
            for x in who.tolist():
                model.layer[x] = layer
        r = assert_update(bp, model)
        events.append((r.pairs.tobytes(), r.created.tobytes(), r.removed.tobytes()))
        assert len(bp) == len(model.boxes)
        # Stale handles are refused.
        if len(gone):
            with pytest.raises(ValueError, match="stale"):
                bp.move(gone[:1], random_boxes(rng, 1))
    return events


@pytest.mark.parametrize("seed", range(3))
def test_random_sequences_equal_brute_force(seed):
    run_sequence(seed, threads=2)


@pytest.mark.parametrize("seed", range(3))
def test_random_sequences_with_queries_between_edits_equal_brute_force(seed):
    run_sequence(100 + seed, threads=2, queries=True)


def test_queries_between_edits_and_update_change_nothing_update_reports():
    """The three ways a query used to hide an edit from update(): a new
    static beside a quiet mover, a moved static, a removed mover."""
    unit = np.array([0, 0, 0, 1, 1, 1], np.float32)

    def at(x):
        return (unit + np.array([x, 0, 0, x, 0, 0], np.float32))[None, :]

    for query in (lambda bp: bp.query_box(np.array([-99, -99, -99, 99, 99, 99], np.float32)),
                  lambda bp: bp.query_boxes(np.array([[-99, -99, -99, 99, 99, 99]], np.float32)),
                  lambda bp: bp.query_ray(np.array([-50, 0.5, 0.5], np.float32),
                                          np.array([1, 0, 0], np.float32), float("inf"))):
        def settled():
            bp = hbp.BroadPhase(threads=2)
            movers = bp.add(np.vstack([at(10 * i) for i in range(5)]))
            wall = bp.add(at(0.5), static=True)
            for _ in range(3):
                bp.move(movers, np.vstack([at(10 * i) for i in range(5)]))
                bp.update()
            assert bp.update().pairs.tolist() == [[movers[0], wall[0]]]
            return bp, movers, wall

        bp, movers, wall = settled()
        new = bp.add(at(20.5), static=True)
        query(bp)
        assert bp.update().created.tolist() == [[movers[2], new[0]]]

        bp, movers, wall = settled()
        bp.move(wall, at(30.5))
        query(bp)
        r = bp.update()
        assert r.created.tolist() == [[movers[3], wall[0]]]
        assert r.removed.tolist() == [[movers[0], wall[0]]]

        bp, movers, wall = settled()
        bp.remove(movers[:1])
        query(bp)
        assert bp.update().removed.tolist() == [[movers[0], wall[0]]]
        for _ in range(2):
            query(bp)
            r = bp.update()
            assert len(r.pairs) == len(r.created) == len(r.removed) == 0


def test_queries_exact_after_refit_of_boxes_spanning_the_float_range():
    big = np.finfo(np.float32).max
    rng = np.random.default_rng(3)
    boxes = random_boxes(rng, 200)
    boxes[::2, 0] = -big
    boxes[::2, 3] = big
    bp = hbp.BroadPhase()
    h = bp.add(boxes)
    everything = np.array([-big, -big, -big, big, big, big], np.float32)
    for step in range(3):
        bp.update()
        np.testing.assert_array_equal(bp.query_box(everything), h)
        q = random_boxes(rng, 1, size=10.0)[0]
        want = h[np.all((boxes[:, 3:] >= q[:3]) & (boxes[:, :3] <= q[3:]), axis=1)]
        np.testing.assert_array_equal(bp.query_box(q), want)
        boxes[:, 1] += 0.5
        boxes[:, 4] += 0.5
        bp.move(h, boxes)  # the moving objects' query tree is refitted, not rebuilt


def test_stats_count_objects_whose_box_changed():
    bp = hbp.BroadPhase()
    h = bp.add(random_boxes(np.random.default_rng(1), 10))
    s = bp.add(np.array([[100, 100, 100, 101, 101, 101]], np.float32), static=True)
    bp.update()
    assert (bp.stats["moved"], bp.stats["static_changes"]) == (10, 1)
    b1 = bp.box(h[1])
    bp.move(h[1:2], (b1 + 1)[None, :])
    bp.move(h[1:2], (b1 + 2)[None, :])   # the same object again
    bp.move(h[2:3], bp.box(h[2])[None, :])  # to its own box
    bp.move(s, bp.box(s[0])[None, :])
    bp.update()
    assert (bp.stats["moved"], bp.stats["static_changes"]) == (1, 0)


def test_same_events_for_one_and_two_threads():
    assert run_sequence(11, threads=1, frames=10) == run_sequence(11, threads=2, frames=10)


def test_removing_an_object_removes_its_pairs():
    bp = hbp.BroadPhase()
    h = bp.add(np.array([[0, 0, 0, 2, 2, 2], [1, 1, 1, 3, 3, 3], [1, 1, 1, 1.5, 1.5, 1.5]], np.float32))
    r = bp.update()
    assert r.created.tolist() == [[h[0], h[1]], [h[0], h[2]], [h[1], h[2]]]
    bp.remove(h[1:2])
    r = bp.update()
    assert r.pairs.tolist() == [[h[0], h[2]]]
    assert r.created.tolist() == []
    assert r.removed.tolist() == [[h[0], h[1]], [h[1], h[2]]]
    pairs, created, removed = bp.update()  # nothing changed: no events
    assert pairs.tolist() == [[h[0], h[2]]] and len(created) == 0 and len(removed) == 0


def test_static_static_pairs_are_never_reported():
    bp = hbp.BroadPhase()
    s = bp.add(np.array([[0, 0, 0, 1, 1, 1], [0.5, 0, 0, 1.5, 1, 1]], np.float32), static=True)
    assert bp.update().pairs.tolist() == []
    m = bp.add(np.array([[0.8, 0, 0, 0.9, 1, 1]], np.float32))
    assert bp.update().pairs.tolist() == [[s[0], m[0]], [s[1], m[0]]]
    assert bp.is_static(s[0]) and not bp.is_static(m[0])
    st = bp.stats
    assert (st["moving"], st["statics"], st["moved"], st["static_changes"]) == (1, 2, 1, 0)
    bp.move(s[:1], np.array([[5, 5, 5, 6, 6, 6]], np.float32))
    assert bp.update().removed.tolist() == [[s[0], m[0]]]
    assert bp.stats["static_changes"] == 1


def test_pair_filter_is_applied_and_removable():
    rng = np.random.default_rng(5)
    bp = hbp.BroadPhase(threads=2)
    model = Model()
    boxes = random_boxes(rng, 200)
    h = bp.add(boxes)
    model.add(h, boxes, False, 0)
    assert_update(bp, model)

    def keep(a, b):
        return (a + b) % 3 != 0

    bp.set_pair_filter(keep)
    model.filter = keep
    r = assert_update(bp, model)
    assert len(r.removed) > 0 and all((a + b) % 3 == 0 for a, b in r.removed.tolist())
    bp.set_pair_filter(None)
    model.filter = None
    r = assert_update(bp, model)
    assert len(r.created) > 0


def test_pair_filter_exception_is_raised_by_update():
    bp = hbp.BroadPhase()
    bp.add(np.array([[0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1]], np.float32))

    def broken(a, b):
        raise KeyError("from the filter")

    bp.set_pair_filter(broken)
    with pytest.raises(KeyError, match="from the filter"):
        bp.update()
    bp.set_pair_filter(lambda a, b: True)
    r = bp.update()  # the failed frame was not applied: its pair is created now
    assert len(r.pairs) == 1 and r.created.tolist() == r.pairs.tolist()
    bp.set_pair_filter(lambda a, b: bp.layer(a) == 0)  # would wait for itself: refused
    with pytest.raises(RuntimeError, match="pair filter cannot call its BroadPhase"):
        bp.update()
    bp.set_pair_filter(None)
    assert len(bp.update().pairs) == 1
    with pytest.raises(ValueError, match="callable"):
        bp.set_pair_filter(3)


@pytest.mark.parametrize("threads", [1, 2])
def test_raising_filter_loses_no_event(threads):
    """A filter that raises leaves the frame unapplied: the next update()
    reports every change since the last completed one, a contact's end
    included."""
    rng = np.random.default_rng(8)
    bp = hbp.BroadPhase(threads=threads)
    model = Model()
    boxes = random_boxes(rng, 300)
    h = bp.add(boxes)
    model.add(h, boxes, False, 0)
    s = bp.add(boxes[:5] + 0.25, static=True)
    model.add(s, boxes[:5] + 0.25, True, 0)
    assert_update(bp, model)
    stats = bp.stats
    calls = []

    def flaky(a, b):
        calls.append((a, b))
        if len(calls) == 3:
            raise ValueError("flaky filter")
        return True

    moved = random_boxes(rng, 300)
    bp.move(h, moved)
    model.move(h, moved)
    bp.set_pair_filter(flaky)
    with pytest.raises(ValueError, match="flaky filter"):
        bp.update()
    assert bp.stats == stats, "the failed frame's stats are not published"
    bp.set_pair_filter(None)
    r = assert_update(bp, model)  # created and removed since the last completed update
    assert len(r.removed) > 0 and len(r.created) > 0
    assert bp.stats["moved"] == 300


def test_threads_limit():
    assert hbp.MAX_THREADS == 1024
    hbp.BroadPhase(threads=hbp.MAX_THREADS).update()
    for bad in (hbp.MAX_THREADS + 1, 65537, 2**31, 2**32, 2**64, -1):
        with pytest.raises(ValueError, match="threads"):
            hbp.BroadPhase(threads=bad)
        with pytest.raises(ValueError, match="threads"):
            hbp.find_pairs(np.zeros((2, 6), np.float32), threads=bad)


def test_accessors_and_options():
    bp = hbp.BroadPhase(engine="sw", threads=1, cell_limit=64, max_pairs=1000)
    assert (bp.engine, bp.threads, bp.cell_limit, bp.max_pairs) == ("sw", 1, 64, 1000)
    box = np.array([[1, 2, 3, 4, 5, 6]], np.float32)
    h = bp.add(box, static=True, layer=7)
    assert len(bp) == 1 and h[0] in bp and bp.contains(int(h[0]))
    assert bp.box(h[0]).dtype == np.float32
    np.testing.assert_array_equal(bp.box(h[0]), box[0])
    assert bp.layer(h[0]) == 7 and bp.is_static(h[0])
    bp.set_layer(h, 9)
    assert bp.layer(h[0]) == 9
    bp.remove(h)
    assert len(bp) == 0 and h[0] not in bp and -1 not in bp and "x" not in bp
    assert set(bp.stats) == {"moving", "statics", "moved", "static_changes", "wall_ms"}


def test_query_box_equals_brute_force():
    rng = np.random.default_rng(9)
    bp = hbp.BroadPhase()
    model = Model()
    for static in (True, False):
        boxes = random_boxes(rng, 300)
        model.add(bp.add(boxes, static=static), boxes, static, 0)
    bp.remove(np.array(sorted(model.boxes)[:20], np.uint32))
    model.remove(np.array(sorted(model.boxes)[:20], np.uint32))
    # Queries see edits before update().
    total = 0
    for q in random_boxes(rng, 50, size=10.0):
        got = bp.query_box(q)
        assert got.dtype == np.uint32
        np.testing.assert_array_equal(got, model.query_box(q))
        total += len(got)
    assert total > 100
    # Touching the query box counts.
    b = np.array(model.boxes[sorted(model.boxes)[0]])
    touching = np.concatenate([b[3:], b[3:] + 1]).astype(np.float32)
    assert sorted(model.boxes)[0] in bp.query_box(touching).tolist()
    # Batched: the same answers, row by row.
    qs = random_boxes(rng, 30, size=10.0)
    offsets, hits = bp.query_boxes(qs)
    assert offsets.shape == (31,) and offsets[0] == 0 and offsets[-1] == len(hits)
    for i, q in enumerate(qs):
        np.testing.assert_array_equal(hits[offsets[i]:offsets[i + 1]], model.query_box(q))
    offsets, hits = bp.query_boxes(np.zeros((0, 6), np.float32))
    assert offsets.tolist() == [0] and len(hits) == 0


def test_query_ray_equals_brute_force_sorted_by_entry():
    rng = np.random.default_rng(10)
    bp = hbp.BroadPhase()
    boxes = random_boxes(rng, 400)
    h = bp.add(boxes)
    total = 0
    for _ in range(60):
        origin = rng.uniform(0, 40, 3).astype(np.float32)
        direction = rng.normal(0, 1, 3).astype(np.float32)
        if rng.random() < 0.2:
            direction[int(rng.integers(0, 3))] = 0  # axis-parallel components
        max_t = float(rng.uniform(20, 80))
        got = bp.query_ray(origin, direction, max_t)
        t = ray_entry(boxes, origin, direction, max_t)
        want = set(h[np.isfinite(t)].tolist())
        assert set(got.tolist()) == want
        t_of = dict(zip(h.tolist(), t))
        ts = np.array([t_of[x] for x in got.tolist()])
        assert np.all(np.diff(ts) >= -1e-4), "not sorted by entry t"
        total += len(got)
    assert total > 50


def test_ray_from_inside_enters_at_zero_and_max_t_limits():
    bp = hbp.BroadPhase()
    h = bp.add(np.array([[0, 0, 0, 2, 2, 2], [5, 0, 0, 6, 2, 2], [3, 0, 0, 4, 2, 2]], np.float32))
    o = np.array([1, 1, 1], np.float32)
    d = np.array([1, 0, 0], np.float32)
    assert bp.query_ray(o, d, 10.0).tolist() == [h[0], h[2], h[1]]
    assert bp.query_ray(o, d, 2.0).tolist() == [h[0], h[2]]  # touches x = 3 at t = 2
    assert bp.query_ray(o, d, 1.5).tolist() == [h[0]]
    assert bp.query_ray(o, -d, 10.0).tolist() == [h[0]]
    assert bp.query_ray(o, d, float("inf")).tolist() == [h[0], h[2], h[1]]  # the whole ray


def test_threads_sharing_one_broad_phase_with_a_python_filter():
    """update() on one Python thread (its filter needs the GIL on the C++
    worker threads) while another thread queries: no deadlock, exact results."""
    import threading
    rng = np.random.default_rng(12)
    boxes = random_boxes(rng, 300)
    bp = hbp.BroadPhase(threads=2)
    h = bp.add(boxes)
    bp.set_pair_filter(lambda a, b: a % 2 == 0)
    model = Model()
    model.add(h, boxes, False, 0)
    model.filter = lambda a, b: a % 2 == 0
    want = model.frame_pairs()
    errors = []

    def updater():
        try:
            for _ in range(20):
                np.testing.assert_array_equal(bp.update().pairs, want)
        except Exception as e:  # reported below
            errors.append(e)

    def reader():
        try:
            for _ in range(200):
                assert len(bp) == 300 and len(bp.query_box(boxes[0])) >= 1
        except Exception as e:
            errors.append(e)

    threads = [threading.Thread(target=updater), threading.Thread(target=reader)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    assert not any(t.is_alive() for t in threads), "deadlock"
    assert not errors, errors


def test_reserve_changes_no_result():
    # More moving objects than a cell holds: the partition runs, and reserve()
    # provisioned its memory before the first update.
    rng = np.random.default_rng(17)
    boxes = random_boxes(rng, 6000, extent=250.0, size=12.0)
    plain, reserved = hbp.BroadPhase(threads=2), hbp.BroadPhase(threads=2)
    reserved.reserve(len(boxes))
    h = plain.add(boxes)
    np.testing.assert_array_equal(reserved.add(boxes), h)
    for frame in range(4):
        a, b = plain.update(), reserved.update()
        for name in ("pairs", "created", "removed"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=f"{name}, frame {frame}")
        want = np.sort(h[hbp.find_pairs(boxes, engine="brute")], axis=1)
        want = want[np.lexsort((want[:, 1], want[:, 0]))]
        np.testing.assert_array_equal(a.pairs, want, err_msg=f"frame {frame}")
        assert len(a.pairs) > 1000
        drift = rng.normal(0, 1.5, (len(boxes), 3)).astype(np.float32)
        boxes = boxes + np.hstack([drift, drift])
        plain.move(h, boxes)
        reserved.move(h, boxes)
