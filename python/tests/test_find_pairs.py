# SPDX-License-Identifier: MIT
"""find_pairs against brute force: random scenes, touching faces, identical
boxes, empty input, n = 1, engines and thread counts."""
import numpy as np
import pytest

import hybrid_broadphase as hbp
from hbp_reference import brute_pairs


def random_boxes(rng, n, extent=50.0, size=6.0):
    lo = rng.uniform(0, extent, (n, 3)).astype(np.float32)
    return np.hstack([lo, lo + rng.uniform(0.1, size, (n, 3)).astype(np.float32)]).astype(np.float32)


def check(boxes, **kw):
    got = hbp.find_pairs(boxes, **kw)
    want = brute_pairs(boxes)
    assert got.dtype == np.uint32 and got.ndim == 2 and got.shape[1] == 2
    np.testing.assert_array_equal(got, want)
    return got


@pytest.mark.parametrize("seed", range(4))
def test_random_scenes_equal_brute_force(seed):
    rng = np.random.default_rng(seed)
    boxes = random_boxes(rng, 400 + 100 * seed)
    got = check(boxes)
    assert len(got) > 50  # the scene has pairs to get wrong
    assert np.all(got[:, 0] < got[:, 1])


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("engine", ["sw", "brute"])
def test_engines_and_threads_agree(engine, threads):
    boxes = random_boxes(np.random.default_rng(7), 600)
    check(boxes, engine=engine, threads=threads)


@pytest.mark.parametrize("engine", ["ae", "mo", "ae-sim", "mo-sim"])
def test_hardware_model_engines_are_registered_at_import(engine):
    boxes = random_boxes(np.random.default_rng(9), 300)
    check(boxes, engine=engine, threads=1)


def _has_engine(name):
    try:
        hbp.find_pairs(np.zeros((0, 6), np.float32), engine=name)
        return True
    except ValueError:  # unknown engine: the build has no CUDA room
        return False
    except RuntimeError:  # known, but no device
        return True


@pytest.mark.parametrize("threads", [1, 2])
def test_cuda_host_engine_equals_brute_force(threads):
    if not _has_engine("cuda-host"):
        pytest.skip("built without the CUDA room (HBP_CUDA)")
    for seed in range(3):
        boxes = random_boxes(np.random.default_rng(40 + seed), 700)
        assert len(check(boxes, engine="cuda-host", threads=threads)) > 50
    check(np.tile(np.array([[1, 1, 1, 2, 2, 2]], np.float32), (60, 1)), engine="cuda-host")


def test_cuda_engine_needs_a_device_or_equals_brute_force():
    if not _has_engine("cuda"):
        pytest.skip("built without the CUDA room (HBP_CUDA)")
    boxes = random_boxes(np.random.default_rng(50), 500)
    try:
        got = hbp.find_pairs(boxes, engine="cuda")
    except RuntimeError as e:  # no GPU here: said so, nothing returned
        assert "no CUDA device found" in str(e)
        return
    np.testing.assert_array_equal(got, brute_pairs(boxes))


def test_small_cell_limit_splits_and_stays_exact():
    boxes = random_boxes(np.random.default_rng(8), 500)
    check(boxes, cell_limit=16, threads=2)


def test_touching_faces_edges_and_corners_overlap():
    boxes = np.array([
        [0, 0, 0, 1, 1, 1],
        [1, 0, 0, 2, 1, 1],   # shares the face x = 1 with 0
        [2, 1, 1, 3, 2, 2],   # shares only the corner (2, 1, 1) with 1
        [3.5, 0, 0, 4, 1, 1],  # gap of 0.5 to 2
        [-1, -1, -1, 0, 0, 0],  # corner (0, 0, 0) with 0
    ], np.float32)
    got = check(boxes)
    assert got.tolist() == [[0, 1], [0, 4], [1, 2]]


def test_identical_and_degenerate_boxes():
    box = [5, 5, 5, 6, 6, 6]
    point = [5.5, 5.5, 5.5, 5.5, 5.5, 5.5]  # zero volume, inside
    boxes = np.array([box, box, box, point, [10, 10, 10, 10, 10, 10]], np.float32)
    got = check(boxes)
    assert got.tolist() == [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]


def test_empty_and_single_box():
    for n in (0, 1):
        got = hbp.find_pairs(np.zeros((n, 6), np.float32))
        assert got.shape == (0, 2) and got.dtype == np.uint32


def test_all_overlapping_cluster():
    boxes = np.tile(np.array([[0, 0, 0, 1, 1, 1]], np.float32), (40, 1))
    assert len(check(boxes)) == 40 * 39 // 2


def test_non_contiguous_input_is_read_correctly():
    rng = np.random.default_rng(3)
    wide = np.zeros((300, 12), np.float32)
    wide[:, ::2] = random_boxes(rng, 300)  # a strided (n, 6) view
    view = wide[:, ::2]
    assert not view.flags.c_contiguous
    np.testing.assert_array_equal(hbp.find_pairs(view), brute_pairs(np.ascontiguousarray(view)))
    fortran = np.asfortranarray(random_boxes(rng, 200))
    np.testing.assert_array_equal(hbp.find_pairs(fortran), brute_pairs(np.ascontiguousarray(fortran)))


def test_max_pairs_raises_capacity_exceeded():
    boxes = np.tile(np.array([[0, 0, 0, 1, 1, 1]], np.float32), (10, 1))
    assert len(hbp.find_pairs(boxes, max_pairs=45)) == 45
    with pytest.raises(hbp.CapacityExceeded):
        hbp.find_pairs(boxes, max_pairs=44)
    assert issubclass(hbp.CapacityExceeded, RuntimeError)


def test_version():
    assert isinstance(hbp.__version__, str) and hbp.__version__.count(".") == 2
