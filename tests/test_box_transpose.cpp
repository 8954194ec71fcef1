// SPDX-License-Identifier: MIT
// detail::check_and_transpose (the one-pass check of BroadPhase::move() of
// every moving object): the lanes against a plain copy, and the verdict
// against box_defect and the id comparison, for every batch length and start
// up to a few vectors (the SSE2 body and the scalar tail), with one bad
// coordinate or id at each row; and batches large enough for the
// non-temporal stores (aligned lanes), and the same lanes misaligned.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "pipeline/box_transpose.hpp"

namespace {

using hbp::Aabb;

std::vector<Aabb> random_boxes(std::size_t n, std::mt19937& rng) {
  std::uniform_real_distribution<float> pos(-100, 100), side(0, 5);
  std::vector<Aabb> boxes(n);
  for (Aabb& b : boxes)
    for (int k = 0; k < 3; ++k) {
      b.min[k] = pos(rng);
      b.max[k] = b.min[k] + (rng() % 7 == 0 ? 0.0f : side(rng));  // some flat boxes: min == max is fine
    }
  return boxes;
}

struct Lanes {
  std::vector<float> data;
  float* lane[6];
  explicit Lanes(std::size_t n) : data(6 * (n + 1), -1.0f) {
    for (int l = 0; l < 6; ++l) lane[l] = data.data() + l * (n + 1);
  }
};

bool expected_verdict(const std::vector<Aabb>& boxes, const std::vector<std::uint32_t>& ids,
                      const std::uint32_t* expected, std::size_t begin, std::size_t end) {
  for (std::size_t i = begin; i < end; ++i) {
    if (hbp::box_defect(boxes[i])) return false;
    if (ids[i] != (expected ? expected[i] : static_cast<std::uint32_t>(i))) return false;
  }
  return true;
}

TEST(BoxTranspose, LanesAndVerdictMatchScalarRule) {
  std::mt19937 rng(3);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::size_t verdicts_false = 0, verdicts_true = 0;
  for (std::size_t n = 0; n <= 19; ++n) {
    const std::vector<Aabb> good = random_boxes(n, rng);
    std::vector<std::uint32_t> identity(n), shifted(n);
    for (std::size_t i = 0; i < n; ++i) {
      identity[i] = static_cast<std::uint32_t>(i);
      shifted[i] = static_cast<std::uint32_t>(3 * i + 1);
    }
    for (std::size_t begin = 0; begin <= std::min<std::size_t>(n, 5); ++begin) {
      // bad: -1 none; else row * 8 + kind (kinds: NaN, +inf, -inf, min > max, wrong id).
      for (int bad = -1; bad < static_cast<int>(n) * 8; ++bad) {
        const int row = bad < 0 ? -1 : bad / 8, kind = bad < 0 ? -1 : bad % 8;
        if (kind > 5) continue;
        for (const bool use_expected : {false, true}) {
          std::vector<Aabb> boxes = good;
          std::vector<std::uint32_t> ids = use_expected ? shifted : identity;
          const int axis = static_cast<int>(rng() % 3);
          if (kind == 0) boxes[row].min[axis] = nan;
          if (kind == 1) boxes[row].max[axis] = inf;
          if (kind == 2) boxes[row].min[axis] = -inf;
          if (kind == 3) boxes[row].min[axis] = boxes[row].max[axis] + 0.5f;
          if (kind == 4) ids[row] += 1;
          if (kind == 5) boxes[row].max[axis] = nan;
          Lanes out(n);
          const bool got = hbp::detail::check_and_transpose(boxes.data(), ids.data(),
                                                            use_expected ? shifted.data() : nullptr, begin, n,
                                                            out.lane);
          const bool want =
              expected_verdict(boxes, ids, use_expected ? shifted.data() : nullptr, begin, n);
          ASSERT_EQ(got, want) << "n " << n << " begin " << begin << " row " << row << " kind " << kind;
          (want ? verdicts_true : verdicts_false) += 1;
          if (!want) continue;
          for (std::size_t i = 0; i < n + 1; ++i)
            for (int k = 0; k < 3; ++k) {
              const bool inside = i >= begin && i < n;
              ASSERT_EQ(out.lane[k][i], inside ? boxes[i].min[k] : -1.0f) << "row " << i;
              ASSERT_EQ(out.lane[3 + k][i], inside ? boxes[i].max[k] : -1.0f) << "row " << i;
            }
        }
      }
    }
  }
  EXPECT_GT(verdicts_true, 100u);
  EXPECT_GT(verdicts_false, 1000u);
}

// With `stream`, batches take the streamed stores when the lanes are 16-byte
// aligned at `begin` (BoxArray lanes, begin a multiple of 4) and the plain
// stores otherwise: both write the same lanes and give the same verdict as
// without, with a bad row early, in the middle and in the scalar tail.
TEST(BoxTranspose, LargeBatchesStreamedOrNotMatchScalarRule) {
  std::mt19937 rng(5);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const std::size_t n : {4096, 4099, 9003}) {
    const std::vector<Aabb> good = random_boxes(n, rng);
    std::vector<std::uint32_t> ids(n);
    for (std::size_t i = 0; i < n; ++i) ids[i] = static_cast<std::uint32_t>(i);
    for (const std::size_t begin : {std::size_t{0}, std::size_t{4}, std::size_t{1}, std::size_t{3}}) {
      for (const long bad : {-1L, static_cast<long>(begin), static_cast<long>(n / 2), static_cast<long>(n - 1)}) {
        for (const bool wrong_id : {false, true}) {
          std::vector<Aabb> boxes = good;
          std::vector<std::uint32_t> id = ids;
          if (bad >= 0 && wrong_id) id[static_cast<std::size_t>(bad)] += 7;
          if (bad >= 0 && !wrong_id) boxes[static_cast<std::size_t>(bad)].max[1] = nan;
          for (const bool stream : {true, false}) {
            hbp::BoxArray out(n);
            float* lane[6];
            for (int k = 0; k < 3; ++k) {
              lane[k] = out.min(k);
              lane[3 + k] = out.max(k);
            }
            const bool got =
                hbp::detail::check_and_transpose(boxes.data(), id.data(), nullptr, begin, n, lane, stream);
            ASSERT_EQ(got, expected_verdict(boxes, id, nullptr, begin, n)) << n << " " << begin << " " << bad;
            ASSERT_EQ(got, bad < 0);
            if (!got) continue;
            for (std::size_t i = begin; i < n; ++i)
              for (int k = 0; k < 3; ++k) {
                ASSERT_EQ(lane[k][i], boxes[i].min[k]) << "row " << i;
                ASSERT_EQ(lane[3 + k][i], boxes[i].max[k]) << "row " << i;
              }
          }
        }
      }
    }
  }
}

}  // namespace

namespace {

// The changed-box count of the same pass: against previous lanes that
// differ from the batch in one coordinate of some rows (each of the six,
// and -0 against +0, which is no change), for every length and start up to
// a few vectors and a streamed batch.
TEST(BoxTranspose, CountsBoxesThatDifferFromThePreviousLanes) {
  std::mt19937 rng(5);
  for (std::size_t n : {0u, 1u, 3u, 4u, 5u, 8u, 13u, 19u, 1u << 16}) {
    std::vector<Aabb> boxes = random_boxes(n, rng);
    std::vector<std::uint32_t> ids(n);
    for (std::size_t i = 0; i < n; ++i) ids[i] = static_cast<std::uint32_t>(i);
    Lanes previous(n);
    std::size_t changed_rows = 0;
    for (std::size_t i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) {
        previous.lane[k][i] = boxes[i].min[k];
        previous.lane[3 + k][i] = boxes[i].max[k];
      }
      const std::size_t what = rng() % 9;
      if (what < 6) {
        previous.lane[what][i] += 1.0f;
        ++changed_rows;
      } else if (what == 6) {  // -0 against +0: the same box
        boxes[i].min[0] = 0.0f;
        boxes[i].max[0] = std::max(boxes[i].max[0], 1.0f);
        previous.lane[0][i] = -0.0f;
        previous.lane[3][i] = boxes[i].max[0];
      }
    }
    for (std::size_t begin : {std::size_t{0}, std::size_t{1}, std::size_t{4}}) {
      if (begin > n) continue;
      std::size_t want = 0;
      for (std::size_t i = begin; i < n; ++i) {
        bool differs = false;
        for (int k = 0; k < 3; ++k)
          differs |= previous.lane[k][i] != boxes[i].min[k] || previous.lane[3 + k][i] != boxes[i].max[k];
        want += differs;
      }
      for (bool stream : {false, true}) {
        hbp::BoxArray lanes(n);
        float* lane[6] = {lanes.min(0), lanes.min(1), lanes.min(2), lanes.max(0), lanes.max(1), lanes.max(2)};
        std::uint32_t changed = 12345;
        ASSERT_TRUE(hbp::detail::check_and_transpose(boxes.data(), ids.data(), nullptr, begin, n, lane, stream,
                                                     previous.lane, &changed));
        EXPECT_EQ(changed, want) << "n " << n << " begin " << begin << " stream " << stream;
      }
    }
    if (n > 100) {
      EXPECT_GT(changed_rows, n / 2);
    }
  }
}

}  // namespace
