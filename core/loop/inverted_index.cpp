#include "core/loop/inverted_index.hpp"

#include <cmath>

namespace ums::loop {

InvertedIndex::InvertedIndex(std::size_t words)
    : words_(words),
      head_(new std::int32_t[words]),
      postings_(new Posting[kPostings]),
      scores_(new float[capacity::kMaxKeyframes]()),
      touched_(new std::uint32_t[capacity::kMaxKeyframes]),
      marked_(new std::uint8_t[capacity::kMaxKeyframes]()) {
  for (std::size_t w = 0; w < words; ++w) head_[w] = -1;
  for (std::size_t i = 0; i < kPostings; ++i)
    postings_[i] = Posting{0, 0.0f, i + 1 < kPostings ? static_cast<std::int32_t>(i + 1) : -1};
}

InvertedIndex::~InvertedIndex() = default;

std::size_t InvertedIndex::footprint_bytes() const {
  return sizeof(*this) + words_ * sizeof(std::int32_t) + kPostings * sizeof(Posting) +
         capacity::kMaxKeyframes * (sizeof(float) + sizeof(std::uint32_t) + 1);
}

Status InvertedIndex::add(std::uint32_t slot, const BowVector& bow) {
  if (slot >= capacity::kMaxKeyframes) return Status::kInvalidInput;
  for (std::size_t i = 0; i < bow.size(); ++i)
    if (bow[i].word >= words_) return Status::kInvalidInput;
  if (in_use_ + bow.size() > kPostings) return Status::kFull;
  for (std::size_t i = 0; i < bow.size(); ++i) {
    const std::int32_t p = free_;
    free_ = postings_[p].next;
    postings_[p] = Posting{slot, bow[i].weight, head_[bow[i].word]};
    head_[bow[i].word] = p;
  }
  in_use_ += bow.size();
  return Status::kOk;
}

void InvertedIndex::remove(std::uint32_t slot, const BowVector& bow) {
  for (std::size_t i = 0; i < bow.size(); ++i) {
    if (bow[i].word >= words_) continue;
    std::int32_t* link = &head_[bow[i].word];
    while (*link >= 0) {
      const std::int32_t p = *link;
      if (postings_[p].slot != slot) {
        link = &postings_[p].next;
        continue;
      }
      *link = postings_[p].next;
      postings_[p].next = free_;
      free_ = p;
      --in_use_;
      break;
    }
  }
}

void InvertedIndex::accumulate(const BowVector& q) const {
  n_touched_ = 0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    if (q[i].word >= words_) continue;
    const float a = q[i].weight;
    for (std::int32_t p = head_[q[i].word]; p >= 0; p = postings_[p].next) {
      const Posting& post = postings_[p];
      if (!marked_[post.slot]) {
        marked_[post.slot] = 1;
        touched_[n_touched_++] = post.slot;
      }
      scores_[post.slot] += std::fabs(a) + std::fabs(post.weight) - std::fabs(a - post.weight);
    }
  }
}

}  // namespace ums::loop
