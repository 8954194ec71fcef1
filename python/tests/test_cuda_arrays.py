# SPDX-License-Identifier: MIT
"""find_pairs(..., engine="cuda"): the whole frame on the GPU. Boxes exposing
__cuda_array_interface__ (CuPy arrays, PyTorch CUDA tensors) are read in
device memory and the pairs come back as a CudaPairs left there. The
interface is checked before any device work, so its errors are tested here
with stand-in objects; the device runs need a GPU and CuPy or PyTorch and
skip otherwise, unless HBP_REQUIRE_GPU=1 (scripts/gpu-check on a GPU
machine), which makes each such skip a failure, as in test_cuda_device."""
import os

import numpy as np
import pytest

import hybrid_broadphase as hbp
from hbp_reference import brute_pairs

# On the GPU machine a missing device, CUDA room or array library must not
# pass as a skip.
REQUIRE_GPU = os.environ.get("HBP_REQUIRE_GPU") == "1"


def skip_unless_required(reason, allow_module_level=False):
    if REQUIRE_GPU:
        pytest.fail(f"HBP_REQUIRE_GPU=1 but {reason}", pytrace=False)
    pytest.skip(reason, allow_module_level=allow_module_level)


if not hasattr(hbp, "CudaPairs"):
    skip_unless_required("built without the CUDA room (HBP_CUDA)", allow_module_level=True)


def device_present():
    try:
        hbp.find_pairs(np.zeros((0, 6), np.float32), engine="cuda")
        return True
    except RuntimeError as e:
        assert "no CUDA device found" in str(e)
        return False


def device_array_library(name):
    """CuPy or PyTorch, where there is a device and the library imports; else a skip."""
    if not device_present():
        skip_unless_required("no CUDA device")
    try:
        return __import__(name)
    except ImportError as e:
        skip_unless_required(f"{name} cannot be imported ({e})")


class Interface:
    """An object that only says where a CUDA array would be."""

    def __init__(self, **entries):
        self.__cuda_array_interface__ = dict(
            {"shape": (4, 6), "typestr": "<f4", "data": (0x7f0000000000, False), "version": 3}, **entries)


def random_boxes(rng, n, extent=50.0, size=6.0):
    lo = rng.uniform(0, extent, (n, 3)).astype(np.float32)
    return np.hstack([lo, lo + rng.uniform(0.1, size, (n, 3)).astype(np.float32)]).astype(np.float32)


@pytest.mark.parametrize("entries, message", [
    ({"typestr": "<f8"}, "float32"),
    ({"shape": (4, 5)}, "shape (n, 6)"),
    ({"shape": (4,)}, "shape (n, 6)"),
    ({"strides": (24, 2)}, "whole float32 elements"),
    ({"strides": (24,)}, "two byte strides"),
    ({"data": (0, False)}, "null data"),
    ({"data": 5}, "(pointer, read_only)"),
    ({"data": ("x", False)}, "'data' pointer"),
    ({"data": (-5, False)}, "'data' pointer"),
    ({"data": (0x7f0000000001, False)}, "not aligned to a float"),
    ({"mask": object()}, "masked"),
    ({"shape": ("4", 6)}, "shape"),
    ({"shape": (2**28 + 1, 6)}, "out of range"),
    ({"stream": 0}, "'stream' 0 is not allowed"),
    ({"stream": -1}, "'stream'"),
    ({"stream": 2**64}, "'stream'"),
    ({"stream": "s"}, "'stream'"),
])
def test_a_malformed_interface_is_a_value_error_naming_it(entries, message):
    with pytest.raises(ValueError, match="boxes") as e:
        hbp.find_pairs(Interface(**entries), engine="cuda")
    assert message in str(e.value)


class RaisingInterface:
    """As a PyTorch tensor that requires grad: the interface itself raises."""

    @property
    def __cuda_array_interface__(self):
        raise RuntimeError("Can't get __cuda_array_interface__ on Variable that requires grad. "
                           "If gradients aren't required, use var.detach() to get Variable that doesn't require grad.")


def test_an_interface_that_raises_is_a_value_error_with_its_message():
    with pytest.raises(ValueError, match="detach"):
        hbp.find_pairs(RaisingInterface(), engine="cuda")
    with pytest.raises(ValueError, match="detach"):
        hbp.CudaFrame(launcher="host").update(RaisingInterface())


def test_an_interface_without_its_keys_is_a_value_error():
    obj = Interface()
    del obj.__cuda_array_interface__["data"]
    with pytest.raises(ValueError, match="has no 'data'"):
        hbp.find_pairs(obj, engine="cuda")


def test_cell_limit_is_the_frames_own():
    with pytest.raises(ValueError, match="cell_limit"):
        hbp.find_pairs(np.zeros((3, 6), np.float32), engine="cuda", cell_limit=64)


def test_without_a_device_a_valid_interface_says_so():
    if device_present():
        pytest.skip("a CUDA device is present")
    with pytest.raises(RuntimeError, match="no CUDA device found"):
        hbp.find_pairs(Interface(), engine="cuda")


def test_numpy_boxes_on_the_device_equal_brute_force():
    if not device_present():
        skip_unless_required("no CUDA device")
    boxes = random_boxes(np.random.default_rng(60), 3000)
    got = hbp.find_pairs(boxes, engine="cuda")
    assert len(got) > 100
    np.testing.assert_array_equal(got, brute_pairs(boxes))


@pytest.mark.parametrize("library", ["cupy", "torch"])
def test_device_arrays_stay_on_the_device(library):
    lib = device_array_library(library)
    boxes = random_boxes(np.random.default_rng(61), 3000)
    want = brute_pairs(boxes)
    for order in ("C", "F"):
        host = np.asarray(boxes, order=order)
        if library == "cupy":
            device = lib.asarray(host, order=order)
        else:
            device = lib.as_tensor(boxes, device="cuda")
            if order == "F":
                device = device.t().contiguous().t()  # column-major strides
        pairs = hbp.find_pairs(device, engine="cuda")
        assert isinstance(pairs, hbp.CudaPairs) and pairs.shape == (len(want), 2) and len(pairs) == len(want)
        got = lib.asarray(pairs).get() if library == "cupy" else lib.as_tensor(pairs, device="cuda").cpu().numpy()
        np.testing.assert_array_equal(got, want)


# ---- CudaFrame: the frame kept across frames --------------------------------------------

def test_cuda_frame_on_the_host_launcher_frame_by_frame():
    rng = np.random.default_rng(70)
    frame = hbp.CudaFrame(launcher="host", threads=2)
    frame.reserve(2000)
    boxes = random_boxes(rng, 2000)
    for f in range(4):
        got = frame.update(boxes)
        np.testing.assert_array_equal(got, brute_pairs(boxes))
        info = frame.info()
        assert info["pairs"] == len(got) > 100
        assert info["references"] >= 2000 and info["large"] == 0 and len(info["grid"]) == 3
        assert set(info["times_ms"]) == {"upload", "bounds", "refs", "sort", "count", "fill", "order", "download",
                                         "frame"}
        if f > 0:
            assert info["allocations"] == 0, f"frame {f} allocated"
        boxes = boxes + rng.uniform(-0.5, 0.5, (2000, 1)).astype(np.float32)  # every box moves as one


def test_cuda_frame_orders_and_shapes_give_the_same_pairs():
    boxes = random_boxes(np.random.default_rng(71), 1500)
    want = brute_pairs(boxes)
    for shape in ("columns", "cubes"):
        np.testing.assert_array_equal(hbp.CudaFrame(launcher="host", cell_shape=shape).update(boxes), want)
        unsorted = hbp.CudaFrame(launcher="host", sorted=False, cell_shape=shape).update(boxes)
        assert np.all(unsorted[:, 0] < unsorted[:, 1])
        np.testing.assert_array_equal(unsorted[np.lexsort((unsorted[:, 1], unsorted[:, 0]))], want)


@pytest.mark.parametrize("kwargs, message", [
    ({"launcher": "gpu"}, "launcher: 'device' or 'host', got 'gpu'"),
    ({"cell_shape": "spheres"}, "cell_shape: 'columns' or 'cubes', got 'spheres'"),
    ({"max_pairs": -1}, "max_pairs"),
    ({"threads": -1}, "threads"),
])
def test_cuda_frame_rejects_bad_options(kwargs, message):
    with pytest.raises(ValueError) as e:
        hbp.CudaFrame(**dict({"launcher": "host"}, **kwargs))
    assert message in str(e.value)


def test_cuda_frame_errors_change_nothing():
    frame = hbp.CudaFrame(launcher="host", max_pairs=1000)
    with pytest.raises(ValueError, match="reserve"):
        frame.reserve(-1)
    bad = random_boxes(np.random.default_rng(72), 50)
    bad[17, 1] = np.nan
    with pytest.raises(ValueError, match="17"):
        frame.update(bad)
    one_point = np.tile(np.array([[1, 2, 3, 1, 2, 3]], np.float32), (100, 1))  # 4,950 pairs
    with pytest.raises(hbp.CapacityExceeded, match="max_pairs = 1000"):
        frame.update(one_point)
    assert len(frame.update(one_point[:45])) == 990
    with pytest.raises(ValueError, match="needs launcher='device'"):
        frame.update(Interface())


class FakeStream:
    def __init__(self, **attributes):
        self.__dict__.update(attributes)


@pytest.mark.parametrize("stream, message", [
    (5, "stream: only for boxes in device memory"),
    (FakeStream(ptr=7), "stream: only for boxes in device memory"),
    ("s", r"stream \(an int handle, or a CuPy or PyTorch stream\): must be an integer"),
    (-1, "stream .*must be an integer 0..2"),
    (2**64, "stream .*must be an integer 0..2"),
    (FakeStream(ptr="x"), "stream .*must be an integer"),
    (FakeStream(cuda_stream=-3), "stream .*must be an integer"),
])
def test_a_stream_is_checked_and_only_for_device_arrays(stream, message):
    frame = hbp.CudaFrame(launcher="host")
    with pytest.raises(ValueError, match=message):
        frame.update(random_boxes(np.random.default_rng(74), 10), stream=stream)
    assert len(frame.update(np.tile(np.array([[0, 0, 0, 1, 1, 1]], np.float32), (3, 1)))) == 3


def test_cuda_frame_on_the_device():
    if not device_present():
        with pytest.raises(RuntimeError, match="no CUDA device found"):
            hbp.CudaFrame()
        skip_unless_required("no CUDA device")
    rng = np.random.default_rng(73)
    frame = hbp.CudaFrame()
    frame.reserve(3000)
    for f in range(3):
        boxes = random_boxes(rng, 3000)
        np.testing.assert_array_equal(frame.update(boxes), brute_pairs(boxes))
        assert frame.info()["times_ms"]["frame"] > 0
    try:
        cupy = __import__("cupy")
    except ImportError as e:
        skip_unless_required(f"cupy cannot be imported ({e})")
    # Device results alternate between two frames: from the third update on,
    # a loop that drops each result before the next but one allocates nothing.
    for f in range(5):
        boxes = random_boxes(rng, 3000)
        pairs = frame.update(cupy.asarray(boxes))
        assert isinstance(pairs, hbp.CudaPairs)
        np.testing.assert_array_equal(cupy.asarray(pairs).get(), brute_pairs(boxes))
        if f > 1:
            assert frame.info()["allocations"] == 0, f"update {f} allocated"
    # A result still referenced is never overwritten: its frame is left to it.
    kept_boxes = random_boxes(rng, 3000)
    kept = cupy.asarray(frame.update(cupy.asarray(kept_boxes)))
    for f in range(4):
        frame.update(cupy.asarray(random_boxes(rng, 6000)))
    np.testing.assert_array_equal(kept.get(), brute_pairs(kept_boxes))


@pytest.mark.parametrize("library", ["cupy", "torch"])
def test_cuda_frame_runs_on_the_stream_it_is_given(library):
    lib = device_array_library(library)
    rng = np.random.default_rng(75)
    frame = hbp.CudaFrame()
    for f in range(3):
        boxes = random_boxes(rng, 4000)
        want = brute_pairs(boxes)
        if library == "cupy":
            stream = lib.cuda.Stream(non_blocking=True)
            with stream:
                device = lib.asarray(boxes) * 1  # written on the side stream
                pairs = frame.update(device, stream=stream)
            got = lib.asarray(pairs).get()
        else:
            stream = lib.cuda.Stream()
            with lib.cuda.stream(stream):
                device = lib.as_tensor(boxes, device="cuda") * 1  # written on the side stream; none exported
                pairs = frame.update(device, stream=stream)
            got = lib.as_tensor(pairs, device="cuda").cpu().numpy()
        np.testing.assert_array_equal(got, want)
