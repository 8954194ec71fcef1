#include "hbp/narrow/narrow_phase.hpp"

#include <string>

#include "hbp/error.hpp"

namespace hbp {

std::size_t NarrowPhase::process(const std::vector<Shape>& shapes, const Pair* pairs, std::size_t count,
                                 std::vector<Contact>& out) const {
  const std::size_t before = out.size();
  const std::size_t n = shapes.size();
  for (std::size_t k = 0; k < count; ++k) {
    const Pair p = pairs[k];
    if (p.a >= n || p.b >= n) {
      throw InvalidInput("narrow phase: pair " + std::to_string(p.a) + "-" + std::to_string(p.b) +
                         " names an object beyond the " + std::to_string(n) + " shapes");
    }
    const narrow::Convex a = narrow::make_convex(shapes[p.a]);
    const narrow::Convex b = narrow::make_convex(shapes[p.b]);
    narrow::Hit hit;
    if (!narrow::intersect(a, b, options_.contacts ? &hit : nullptr, options_.method)) continue;
    Contact c;
    c.a = p.a;
    c.b = p.b;
    if (options_.contacts) {
      c.normal = narrow::to_vec3(hit.normal);
      c.depth = hit.depth;
      c.point = narrow::to_vec3(hit.point);
    }
    out.push_back(c);
  }
  return out.size() - before;
}

}  // namespace hbp
