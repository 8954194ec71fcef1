#pragma once
// Reading Bullet's pair cache: proxies carry their object index as the user
// pointer; the cache holds a superset of the exact pairs (fattened DBVT
// leaves, quantised sweep-and-prune endpoints), filtered here with the one
// closed-interval overlap rule of the system.
#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

class btOverlappingPairCache;
class btVector3;

namespace hbp::baselines {

// The user pointer stored in a proxy for object i, and back.
void* bullet_user_pointer(std::uint32_t index);
std::uint32_t bullet_object_index(const void* user_pointer);

// Bullet's min / max corners of box i (single precision, bit-identical).
btVector3 bullet_min(const BoxArray& boxes, std::size_t i);
btVector3 bullet_max(const BoxArray& boxes, std::size_t i);

// Fills `out` with the cache's pairs whose boxes overlap exactly, sorted and
// canonical; returns the cache's raw pair count.
std::size_t exact_bullet_pairs(btOverlappingPairCache& cache, const BoxArray& boxes, std::vector<Pair>& out);

}  // namespace hbp::baselines
