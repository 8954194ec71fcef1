// SPDX-License-Identifier: MIT
// Brute force: every pair tested with the closed-interval rule (the oracle,
// O(n^2)); for small worlds only.
#include <memory>
#include <vector>

#include "hbp/baselines/baseline.hpp"
#include "hbp/brute_force.hpp"

namespace hbp::baselines {
namespace {

class BruteForceBaseline final : public Baseline {
 public:
  std::string name() const override { return "brute"; }
  std::string label() const override { return "Brute force"; }
  void setup(const BoxArray& boxes) override { update(boxes); }
  void update(const BoxArray& boxes) override { pairs_ = brute_force_pairs(boxes); }
  std::size_t raw_pairs() const override { return pairs_.size(); }
  const std::vector<Pair>& exact_pairs() override { return pairs_; }

 private:
  std::vector<Pair> pairs_;
};

}  // namespace

std::unique_ptr<Baseline> make_brute_force_baseline() { return std::make_unique<BruteForceBaseline>(); }

}  // namespace hbp::baselines
