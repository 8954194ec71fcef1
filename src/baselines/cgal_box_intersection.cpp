// SPDX-License-Identifier: MIT
// CGAL's box_self_intersection_d (Zomorodian and Edelsbrunner's streamed
// segment tree): float boxes in 3D, closed topology so touching faces
// intersect, rebuilt from scratch every frame (it keeps no state).
#include <cstdint>
#include <memory>
#include <vector>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wdeprecated-copy"
#include <CGAL/Box_intersection_d/Box_with_info_d.h>
#include <CGAL/box_intersection_d.h>
#pragma GCC diagnostic pop

#include "hbp/baselines/baseline.hpp"

namespace hbp::baselines {
namespace {

// ID_EXPLICIT: CGAL breaks ties between equal coordinates by a unique id,
// which a copied box keeps (box_self_intersection_d copies the range).
using CgalBox = CGAL::Box_intersection_d::Box_with_info_d<float, 3, std::uint32_t,
                                                           CGAL::Box_intersection_d::ID_EXPLICIT>;

class CgalBoxIntersection final : public Baseline {
 public:
  std::string name() const override { return "cgal"; }
  std::string label() const override { return "CGAL"; }

  void setup(const BoxArray& boxes) override { update(boxes); }

  void update(const BoxArray& boxes) override {
    const auto n = static_cast<std::uint32_t>(boxes.size());
    cgal_boxes_.clear();
    cgal_boxes_.reserve(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      float lo[3] = {boxes.min(0)[i], boxes.min(1)[i], boxes.min(2)[i]};
      float hi[3] = {boxes.max(0)[i], boxes.max(1)[i], boxes.max(2)[i]};
      cgal_boxes_.emplace_back(lo, hi, i);
    }
    raw_.clear();
    auto report = [this](const CgalBox& a, const CgalBox& b) { raw_.push_back({a.info(), b.info()}); };
    // Cutoff 10 is CGAL's default; CLOSED makes touching boxes intersect.
    CGAL::box_self_intersection_d(cgal_boxes_.begin(), cgal_boxes_.end(), report, std::ptrdiff_t{10},
                                  CGAL::Box_intersection_d::CLOSED);
    dirty_ = true;
  }

  std::size_t raw_pairs() const override { return raw_.size(); }

  // CGAL's answer is exact: not filtered, so a wrong pair would show as a
  // mismatch against ours. A pair reported twice is merged here (raw_pairs()
  // still counts it).
  const std::vector<Pair>& exact_pairs() override {
    if (dirty_) {
      exact_ = raw_;
      canonicalize(exact_);
      dirty_ = false;
    }
    return exact_;
  }

 private:
  std::vector<CgalBox> cgal_boxes_;
  std::vector<Pair> raw_;
  std::vector<Pair> exact_;
  bool dirty_ = false;
};

}  // namespace

std::unique_ptr<Baseline> make_cgal_box_intersection() { return std::make_unique<CgalBoxIntersection>(); }

}  // namespace hbp::baselines
