# SPDX-License-Identifier: MIT
"""The C API (hbp/hbp.h) through ctypes against libhybrid_broadphase.so:
random batched add / move / remove / set_collides frames, every frame's
pairs, created and removed pairs and box / ray queries (with early-out)
checked against a brute-force oracle in numpy, and the error codes.

The library is the one named by HBP_CAPI_LIBRARY (ctest sets it); the tests
are skipped when it is not set."""
import ctypes as C
import math
import os

import numpy as np
import pytest

LIBRARY = os.environ.get("HBP_CAPI_LIBRARY")
pytestmark = pytest.mark.skipif(not LIBRARY, reason="HBP_CAPI_LIBRARY (path of libhybrid_broadphase.so) not set")

HBP_OK, HBP_ERROR_INVALID_ARGUMENT, HBP_ERROR_CAPACITY = 0, 1, 2


class Box(C.Structure):
    _fields_ = [("min", C.c_float * 3), ("max", C.c_float * 3)]


class Pair(C.Structure):
    _fields_ = [("a", C.c_uint32), ("b", C.c_uint32)]


class Options(C.Structure):
    _fields_ = [("engine", C.c_char_p), ("threads", C.c_uint32), ("cell_limit", C.c_uint32),
                ("max_pairs", C.c_uint64), ("run_tasks", C.c_void_p), ("task_user", C.c_void_p),
                ("double_precision", C.c_int)]


HIT = C.CFUNCTYPE(C.c_int, C.c_void_p, C.c_uint32)


@pytest.fixture(scope="module")
def lib():
    h = C.CDLL(LIBRARY)
    bp = C.c_void_p
    sig = {
        "hbp_version": (C.c_char_p, []),
        "hbp_last_error": (C.c_char_p, []),
        "hbp_options_init": (None, [C.POINTER(Options)]),
        "hbp_create": (C.c_int, [C.POINTER(Options), C.POINTER(bp)]),
        "hbp_destroy": (None, [bp]),
        "hbp_add": (C.c_int, [bp, C.c_void_p, C.c_size_t, C.c_int, C.c_uint8, C.c_void_p]),
        "hbp_move": (C.c_int, [bp, C.c_void_p, C.c_void_p, C.c_size_t]),
        "hbp_remove": (C.c_int, [bp, C.c_void_p, C.c_size_t]),
        "hbp_set_collides": (C.c_int, [bp, C.c_uint32, C.c_uint32, C.c_int]),
        "hbp_update": (C.c_int, [bp]),
        "hbp_pairs": (C.c_int, [bp, C.POINTER(C.POINTER(Pair)), C.POINTER(C.c_size_t)]),
        "hbp_created_pairs": (C.c_int, [bp, C.POINTER(C.POINTER(Pair)), C.POINTER(C.c_size_t)]),
        "hbp_removed_pairs": (C.c_int, [bp, C.POINTER(C.POINTER(Pair)), C.POINTER(C.c_size_t)]),
        "hbp_query_box": (C.c_int, [bp, C.POINTER(Box), HIT, C.c_void_p, C.POINTER(C.c_size_t)]),
        "hbp_query_ray": (C.c_int, [bp, C.POINTER(C.c_float), C.POINTER(C.c_float), C.c_float, HIT, C.c_void_p,
                                    C.POINTER(C.c_size_t)]),
        "hbp_size": (C.c_int, [bp, C.POINTER(C.c_size_t)]),
        "hbp_contains": (C.c_int, [bp, C.c_uint32]),
    }
    for name, (res, args) in sig.items():
        f = getattr(h, name)
        f.restype, f.argtypes = res, args
    return h


def ok(lib, status):
    assert status == HBP_OK, lib.hbp_last_error().decode()


def as_boxes(a):
    """(n, 6) float32 rows min xyz, max xyz: the memory of n hbp_box."""
    return np.ascontiguousarray(a, dtype=np.float32)


def pair_list(lib, bp, fn):
    p = C.POINTER(Pair)()
    n = C.c_size_t()
    ok(lib, fn(bp, C.byref(p), C.byref(n)))
    if n.value == 0:
        return np.zeros((0, 2), np.uint32)
    return np.ctypeslib.as_array(C.cast(p, C.POINTER(C.c_uint32)), shape=(n.value, 2)).copy()


def oracle_pairs(objects, collides):
    hs = sorted(objects)
    if not hs:
        return np.zeros((0, 2), np.uint32)
    b = np.array([objects[h][0] for h in hs], np.float32)
    st = np.array([objects[h][1] for h in hs])
    layer = np.array([objects[h][2] for h in hs])
    ov = np.all((b[:, None, 3:] >= b[None, :, :3]) & (b[:, None, :3] <= b[None, :, 3:]), axis=2)
    ov &= ~(st[:, None] & st[None, :])
    ov &= collides[layer[:, None], layer[None, :]]
    i, j = np.nonzero(np.triu(ov, 1))
    h = np.array(hs, np.uint32)
    return np.stack([h[i], h[j]], axis=1).astype(np.uint32)  # sorted: hs is, and i < j


def setdiff(a, b):
    sb = {tuple(p) for p in b}
    out = [p for p in a if tuple(p) not in sb]
    return np.array(out, np.uint32).reshape(-1, 2)


def ray_oracle(objects, o, d, max_t):
    """The library's float segment test, operation for operation."""
    hits = []
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        inv = np.float32(1) / d
    for h, (box, _, _) in objects.items():
        t0, t1, hit = np.float32(0), np.float32(max_t), True
        for k in range(3):
            if d[k] == 0 or math.isinf(inv[k]):
                if o[k] < box[k] or o[k] > box[3 + k]:
                    hit = False
                    break
                continue
            a = (box[k] - o[k]) * inv[k]
            b = (box[3 + k] - o[k]) * inv[k]
            if a > b:
                a, b = b, a
            t0, t1 = max(t0, a), min(t1, b)
        if hit and t0 <= t1:
            hits.append((float(t0), h))
    return [h for _, h in sorted(hits)]


def query(lib, fn, bp, *args, stop_after=0):
    got = []

    def cb(_, h):
        got.append(h)
        return 0 if stop_after and len(got) >= stop_after else 1

    calls = C.c_size_t()
    ok(lib, fn(bp, *args, HIT(cb), None, C.byref(calls)))
    assert calls.value == len(got)
    return got


def make(lib, threads=1, max_pairs=0, engine=None):
    o = Options()
    lib.hbp_options_init(C.byref(o))
    o.threads, o.max_pairs = threads, max_pairs
    if engine is not None:
        o.engine = engine
    bp = C.c_void_p()
    return lib.hbp_create(C.byref(o), C.byref(bp)), bp


@pytest.mark.parametrize("seed,threads", [(1, 1), (2, 2)])
def test_random_frames_match_the_oracle(lib, seed, threads):
    rng = np.random.default_rng(seed)
    status, bp = make(lib, threads)
    ok(lib, status)
    objects = {}  # handle -> (box (6,) float32, static, layer)
    collides = np.ones((32, 32), bool)
    before = np.zeros((0, 2), np.uint32)
    totals = np.zeros(3, int)
    try:
        for frame in range(25):
            n = 150 if frame == 0 else int(rng.integers(0, 30))
            boxes = as_boxes(np.hstack([lo := rng.integers(0, 60, (n, 3)) * 0.5,
                                        lo + rng.integers(0, 9, (n, 3)) * 0.5]))
            static, layer = bool(rng.random() < 0.25), int(rng.integers(0, 4))
            handles = np.zeros(n, np.uint32)
            ok(lib, lib.hbp_add(bp, boxes.ctypes.data, n, static, layer, handles.ctypes.data))
            objects.update({int(h): (boxes[i], static, layer) for i, h in enumerate(handles)})
            live = np.array(sorted(objects), np.uint32)
            moved = rng.choice(live, min(30, len(live)), replace=False).astype(np.uint32)
            new = as_boxes(np.hstack([lo := rng.integers(0, 60, (len(moved), 3)) * 0.5,
                                      lo + rng.integers(0, 9, (len(moved), 3)) * 0.5]))
            ok(lib, lib.hbp_move(bp, moved.ctypes.data, new.ctypes.data, len(moved)))
            for i, h in enumerate(moved):
                objects[int(h)] = (new[i],) + objects[int(h)][1:]
            gone = rng.choice(live, int(rng.integers(0, 15)), replace=False).astype(np.uint32)
            ok(lib, lib.hbp_remove(bp, gone.ctypes.data, len(gone)))
            for h in gone:
                del objects[int(h)]
                assert lib.hbp_contains(bp, int(h)) == 0
            if frame % 4 == 3:
                la, lb, c = int(rng.integers(0, 4)), int(rng.integers(0, 4)), bool(rng.integers(0, 2))
                ok(lib, lib.hbp_set_collides(bp, la, lb, c))
                collides[la, lb] = collides[lb, la] = c

            ok(lib, lib.hbp_update(bp))
            now = oracle_pairs(objects, collides)
            np.testing.assert_array_equal(pair_list(lib, bp, lib.hbp_pairs), now, err_msg=f"frame {frame}")
            np.testing.assert_array_equal(pair_list(lib, bp, lib.hbp_created_pairs), setdiff(now, before))
            np.testing.assert_array_equal(pair_list(lib, bp, lib.hbp_removed_pairs), setdiff(before, now))
            totals += [len(now), len(setdiff(now, before)), len(setdiff(before, now))]
            before = now
            size = C.c_size_t()
            ok(lib, lib.hbp_size(bp, C.byref(size)))
            assert size.value == len(objects)

            for _ in range(4):
                lo = rng.integers(0, 60, 3) * 0.5
                q = Box((C.c_float * 3)(*lo), (C.c_float * 3)(*(lo + rng.integers(0, 20, 3) * 0.5)))
                qb = np.array(list(q.min) + list(q.max), np.float32)
                want = sorted(h for h, (b, _, _) in objects.items()
                              if np.all(b[3:] >= qb[:3]) and np.all(b[:3] <= qb[3:]))
                assert query(lib, lib.hbp_query_box, bp, C.byref(q)) == want
                assert query(lib, lib.hbp_query_box, bp, C.byref(q), stop_after=1) == want[:1]

                o = (rng.integers(0, 120, 3) * 0.25).astype(np.float32)
                d = ((rng.integers(0, 9, 3) - 4) * 0.5).astype(np.float32)
                max_t = np.float32(np.inf if rng.random() < 0.5 else rng.integers(1, 60) * 0.5)
                want = ray_oracle(objects, o, d, max_t)
                args = ((C.c_float * 3)(*o), (C.c_float * 3)(*d), float(max_t))
                assert query(lib, lib.hbp_query_ray, bp, *args) == want
                assert query(lib, lib.hbp_query_ray, bp, *args, stop_after=2) == want[:2]
    finally:
        lib.hbp_destroy(bp)
    assert totals[0] > 500 and totals[1] > 200 and totals[2] > 150, totals


def test_errors_name_the_culprit_and_change_nothing(lib):
    assert lib.hbp_version().decode().count(".") == 2
    status, bp = make(lib, engine=b"no-such-engine")
    assert status == HBP_ERROR_INVALID_ARGUMENT and not bp.value
    assert "no-such-engine" in lib.hbp_last_error().decode()

    status, bp = make(lib, max_pairs=1)
    ok(lib, status)
    assert lib.hbp_last_error() == b""
    try:
        boxes = as_boxes([[0, 0, 0, 1, 1, 1], [1, 1, 1, 2, 2, 2], [2, 2, 2, 3, 3, float("nan")]])
        h = np.zeros(3, np.uint32)
        assert lib.hbp_add(bp, boxes.ctypes.data, 3, 0, 0, h.ctypes.data) == HBP_ERROR_INVALID_ARGUMENT
        assert "row 2" in lib.hbp_last_error().decode()
        size = C.c_size_t()
        ok(lib, lib.hbp_size(bp, C.byref(size)))
        assert size.value == 0
        boxes[2, 5] = 3
        ok(lib, lib.hbp_add(bp, boxes.ctypes.data, 3, 0, 0, h.ctypes.data))
        assert lib.hbp_update(bp) == HBP_ERROR_CAPACITY  # 2 pairs > max_pairs 1
        assert len(pair_list(lib, bp, lib.hbp_pairs)) == 0
        ok(lib, lib.hbp_remove(bp, h[2:].ctypes.data, 1))
        assert lib.hbp_remove(bp, h[2:].ctypes.data, 1) == HBP_ERROR_INVALID_ARGUMENT
        ok(lib, lib.hbp_update(bp))
        np.testing.assert_array_equal(pair_list(lib, bp, lib.hbp_created_pairs), [[h[0], h[1]]])
        assert lib.hbp_update(None) == HBP_ERROR_INVALID_ARGUMENT
        assert "NULL" in lib.hbp_last_error().decode()
    finally:
        lib.hbp_destroy(bp)
