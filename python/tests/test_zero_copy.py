# SPDX-License-Identifier: MIT
"""Boxes reach C++ without a copy when numpy allows it: a C-contiguous,
aligned float32 (n, 6) array is handed over as hbp::Aabb[n] in place (the
module's private _boxes_address says which address C++ would read)."""
import numpy as np

import hybrid_broadphase as hbp


def test_c_contiguous_float32_is_not_copied():
    boxes = np.zeros((1000, 6), np.float32)
    assert hbp._boxes_address(boxes) == boxes.ctypes.data
    rows = boxes[100:200]  # a contiguous slice of rows is still in place
    assert hbp._boxes_address(rows) == rows.ctypes.data


def test_strided_and_fortran_inputs_are_copied_once():
    wide = np.zeros((50, 12), np.float32)
    view = wide[:, ::2]
    assert hbp._boxes_address(view) != view.ctypes.data
    f = np.asfortranarray(np.zeros((50, 6), np.float32))
    assert hbp._boxes_address(f) != f.ctypes.data


def test_handles_come_back_as_owned_uint32_arrays():
    bp = hbp.BroadPhase()
    h = bp.add(np.zeros((5, 6), np.float32))
    assert h.dtype == np.uint32 and h.flags.c_contiguous and h.flags.owndata is False
    h[0] = 7  # the caller may write its copy; the broad phase is unaffected
    assert len(bp) == 5
