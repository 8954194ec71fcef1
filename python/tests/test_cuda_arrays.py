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
    ({"data": (0, False)}, "null pointer"),
    ({"data": 5}, "(pointer, read_only)"),
    ({"mask": object()}, "masked"),
])
def test_a_malformed_interface_is_a_value_error_naming_it(entries, message):
    with pytest.raises(ValueError, match="boxes") as e:
        hbp.find_pairs(Interface(**entries), engine="cuda")
    assert message in str(e.value)


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
    if not device_present():
        skip_unless_required("no CUDA device")
    try:
        lib = __import__(library)
    except ImportError as e:
        skip_unless_required(f"{library} cannot be imported ({e})")
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
