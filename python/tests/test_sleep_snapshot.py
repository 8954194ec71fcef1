# SPDX-License-Identifier: MIT
"""BroadPhase.set_static (sleeping and waking) and snapshot / restore /
from_snapshot against the brute-force model: randomized frames mixing add,
move, remove and set_static, with snapshots restored into fresh and reused
objects whose next frames must be the original's; errors."""
import numpy as np
import pytest

import hybrid_broadphase as hbp
from hbp_reference import Model


def random_boxes(rng, n, extent=30.0, size=5.0):
    lo = np.round(rng.uniform(0, extent, (n, 3))).astype(np.float32)
    ext = np.round(rng.uniform(0, size, (n, 3))).astype(np.float32)  # touching faces, zero sizes
    return np.hstack([lo, lo + ext]).astype(np.float32)


def check(bps, model):
    pairs, created, removed = model.update()
    for bp in bps:
        r = bp.update()
        np.testing.assert_array_equal(r.pairs, pairs)
        np.testing.assert_array_equal(r.created, created)
        np.testing.assert_array_equal(r.removed, removed)
    return (pairs.tobytes(), created.tobytes(), removed.tobytes())


def edit(rng, bps, model):
    """One frame's random edits, the same to every broad phase and the model."""
    live = np.array(sorted(model.boxes), np.uint32)
    op = int(rng.integers(0, 5))
    if op == 0 and len(live) < 250:
        boxes = random_boxes(rng, int(rng.integers(1, 12)))
        static = bool(rng.random() < 0.3)
        hs = [bp.add(boxes, static=static) for bp in bps]
        for h in hs[1:]:
            np.testing.assert_array_equal(h, hs[0])  # same edits, same handles
        model.add(hs[0], boxes, static, 0)
    elif op == 1 and len(live) > 60:
        gone = rng.choice(live, size=int(rng.integers(1, 8)), replace=False).astype(np.uint32)
        for bp in bps:
            bp.remove(gone)
        model.remove(gone)
    elif op in (2, 3) and len(live):
        who = rng.choice(live, size=min(len(live), int(rng.integers(1, 30))), replace=False)
        static = bool(rng.random() < 0.5)
        for i, bp in enumerate(bps):  # ndarray or list, positional or keyword
            if i % 2:
                bp.set_static(who.tolist(), static=static)
            else:
                bp.set_static(who.astype(np.uint32), static)
        for h in who.tolist():
            model.static[h] = static
    if len(model.boxes):
        live = np.array(sorted(model.boxes), np.uint32)
        sel = rng.choice(live, size=min(len(live), 40), replace=False).astype(np.uint32)
        new = np.array([model.boxes[h] for h in sel.tolist()], np.float32)
        d = np.round(rng.normal(0, 1, (len(sel), 3))).astype(np.float32)
        new[:, :3] += d
        new[:, 3:] += d
        for bp in bps:
            bp.move(sel, new)
        model.move(sel, new)


@pytest.mark.parametrize("threads", [1, 2])
def test_sleep_wake_and_snapshots_equal_brute_force(threads):
    rng = np.random.default_rng(threads)
    bp = hbp.BroadPhase(threads=threads)
    model = Model()
    boxes = random_boxes(rng, 150)
    model.add(bp.add(boxes), boxes, False, 0)
    check([bp], model)
    sleeps = 0
    for round_ in range(6):
        for _ in range(int(rng.integers(5, 30))):
            edit(rng, [bp], model)
            check([bp], model)
        statics_before = bp.stats["statics"]
        edit(rng, [bp], model)  # pending edits go into the snapshot
        data = bp.snapshot()
        assert isinstance(data, bytes)
        fresh = hbp.BroadPhase.from_snapshot(data, threads=3 - threads)
        reused = hbp.BroadPhase(threads=threads)
        reused.add(random_boxes(rng, 20))
        reused.update()
        reused.restore(data)
        assert fresh.snapshot() == data and reused.snapshot() == data
        check([bp, fresh, reused], model)
        sleeps += bp.stats["statics"] != statics_before
        for _ in range(40):
            edit(rng, [bp, fresh, reused], model)
            check([bp, fresh, reused], model)
    assert sleeps > 0


def test_handles_survive_sleep_and_the_pair_rule():
    bp = hbp.BroadPhase()
    a, b, c = bp.add(np.array([[0, 0, 0, 1, 1, 1], [0.5, 0, 0, 1.5, 1, 1], [0, 0.5, 0, 1, 1.5, 1]], np.float32))
    floor = bp.add(np.array([[-5, -1, -5, 5, 0, 5]], np.float32), static=True)[0]
    assert len(bp.update().pairs) == 5
    bp.set_static([a], True)  # partners b, c moving, the floor static
    r = bp.update()
    assert r.created.tolist() == [] and r.removed.tolist() == [[a, floor]]
    assert bp.is_static(a) and a in bp
    bp.set_static(np.array([a], np.uint32), static=False)
    assert bp.update().created.tolist() == [[a, floor]]
    assert bp.stats["moved"] == 1 and bp.stats["static_changes"] == 1


def test_errors_change_nothing():
    bp = hbp.BroadPhase()
    h = bp.add(np.array([[0, 0, 0, 1, 1, 1], [0.5, 0, 0, 1.5, 1, 1]], np.float32))
    gone = bp.add(np.array([[0, 0, 0, 1, 1, 1]], np.float32))
    bp.remove(gone)
    bp.update()
    with pytest.raises(ValueError, match="row 2"):
        bp.set_static([int(h[0]), int(h[1]), int(gone[0])], True)
    with pytest.raises(ValueError, match="repeats row 0"):
        bp.set_static([int(h[0]), int(h[0])], True)
    assert not bp.is_static(int(h[0]))
    data = bp.snapshot()
    for bad, what in ((data[:-1], "truncated"), (data[:5], "not a BroadPhase snapshot"), (b"", "not a BroadPhase"),
                      (data[:8] + b"\x07" + data[9:], "version 7"),
                      (data[:-2] + bytes([data[-2] ^ 1]) + data[-1:], "checksum")):
        with pytest.raises(ValueError, match=what):
            bp.restore(bad)
        with pytest.raises(ValueError, match=what):
            hbp.BroadPhase.from_snapshot(bad)
        assert bp.snapshot() == data
    with pytest.raises(ValueError, match="bytes-like"):
        bp.restore("not bytes")
    r = bp.update()
    assert r.created.tolist() == [] and r.removed.tolist() == [] and r.pairs.tolist() == [[h[0], h[1]]]


def test_restore_keeps_options_and_filter():
    src = hbp.BroadPhase()
    h = src.add(np.array([[0, 0, 0, 1, 1, 1], [0.5, 0, 0, 1.5, 1, 1]], np.float32))
    src.update()
    dst = hbp.BroadPhase(engine="sw", threads=1, max_pairs=10)
    dst.set_pair_filter(lambda a, b: False)
    dst.restore(src.snapshot())
    assert dst.threads == 1 and dst.max_pairs == 10 and len(dst) == 2
    r = dst.update()  # the stored pair, now rejected by dst's own filter
    assert r.pairs.tolist() == [] and r.removed.tolist() == [[h[0], h[1]]]

    class Sub(hbp.BroadPhase):
        pass

    s = Sub.from_snapshot(bytearray(src.snapshot()), max_pairs=5)
    assert isinstance(s, Sub) and s.max_pairs == 5
    assert s.add(np.array([[0, 0, 0, 1, 1, 1]], np.float32)).tolist() == \
        src.add(np.array([[0, 0, 0, 1, 1, 1]], np.float32)).tolist()


def test_from_snapshot_takes_the_snapshots_precision():
    doubles = hbp.BroadPhase(double_precision=True)
    h = doubles.add(np.array([[1e9, 1e9, 1e9, 1e9 + 1, 1e9 + 1, 1e9 + 1],
                              [1e9 + 1, 1e9, 1e9, 1e9 + 2, 1e9 + 1, 1e9 + 1]]))
    doubles.update()
    restored = hbp.BroadPhase.from_snapshot(doubles.snapshot())
    assert restored.double_precision
    assert restored.box(h[1]).dtype == np.float64
    np.testing.assert_array_equal(restored.update().pairs, [[h[0], h[1]]])
    with pytest.raises(ValueError, match="double_precision=False"):
        hbp.BroadPhase.from_snapshot(doubles.snapshot(), double_precision=False)
    with pytest.raises(ValueError, match="double_precision broad phase into a float one"):
        hbp.BroadPhase().restore(doubles.snapshot())
