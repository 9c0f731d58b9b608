#pragma once
// A keyframe's bag of words: (word, weight) sorted by word, TF-IDF weights normalised to an L1
// norm of 1 (DBoW2's default), in fixed storage. The similarity of two is DBoW2's L1 score,
// 1 - |a - b|_1 / 2, in [0, 1]: computed over the words they share, since for each shared word
// |a| + |b| - |a - b| is all that differs from the disjoint case.

#include <cstdint>

#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"

namespace ums::loop {

struct BowEntry {
  std::uint32_t word = 0;
  float weight = 0.0f;
};

using BowVector = FixedVector<BowEntry, capacity::kMaxLoopFeaturesPerKeyframe>;

// Adds weight to word, keeping the order; kFull when the vector has no room for a new word.
Status bow_add(BowVector* v, std::uint32_t word, float weight);
// Divides by the sum of weights (nothing when it is 0).
void bow_normalize_l1(BowVector* v);
// DBoW2's L1 score of two L1-normalised vectors.
float bow_score(const BowVector& a, const BowVector& b);

}  // namespace ums::loop
