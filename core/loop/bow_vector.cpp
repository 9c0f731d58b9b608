#include "core/loop/bow_vector.hpp"

#include <cmath>

namespace ums::loop {

Status bow_add(BowVector* v, std::uint32_t word, float weight) {
  std::size_t i = 0;
  while (i < v->size() && (*v)[i].word < word) ++i;
  if (i < v->size() && (*v)[i].word == word) {
    (*v)[i].weight += weight;
    return Status::kOk;
  }
  if (v->full()) return Status::kFull;
  v->resize(v->size() + 1);
  for (std::size_t j = v->size() - 1; j > i; --j) (*v)[j] = (*v)[j - 1];
  (*v)[i] = BowEntry{word, weight};
  return Status::kOk;
}

void bow_normalize_l1(BowVector* v) {
  float sum = 0.0f;
  for (std::size_t i = 0; i < v->size(); ++i) sum += std::fabs((*v)[i].weight);
  if (!(sum > 0.0f)) return;
  for (std::size_t i = 0; i < v->size(); ++i) (*v)[i].weight /= sum;
}

float bow_score(const BowVector& a, const BowVector& b) {
  float shared = 0.0f;
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (a[i].word < b[j].word) {
      ++i;
    } else if (b[j].word < a[i].word) {
      ++j;
    } else {
      const float x = a[i].weight, y = b[j].weight;
      shared += std::fabs(x) + std::fabs(y) - std::fabs(x - y);
      ++i;
      ++j;
    }
  }
  return 0.5f * shared;
}

}  // namespace ums::loop
