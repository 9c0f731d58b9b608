#pragma once
// The keyframe database's place-recognition index: for each word, the keyframes whose bag of
// words holds it, with the weight. Fixed memory, allocated at construction: word heads for every
// vocabulary node, a posting pool of kMaxKeyframes x kMaxLoopFeaturesPerKeyframe entries linked
// per word (a free list takes back a removed keyframe's postings), and one score per keyframe
// slot. A query visits only the postings of its own words and scores with DBoW2's L1 score.

#include <cstdint>
#include <memory>

#include "core/common/capacity.hpp"
#include "core/common/status.hpp"
#include "core/loop/bow_vector.hpp"

namespace ums::loop {

struct IndexHit {
  std::uint32_t keyframe = 0;  // the slot given to add()
  float score = 0.0f;          // L1 score in [0, 1]
};

class InvertedIndex {
 public:
  // words: the vocabulary's node count (word ids are below it).
  explicit InvertedIndex(std::size_t words);
  ~InvertedIndex();
  InvertedIndex(const InvertedIndex&) = delete;
  InvertedIndex& operator=(const InvertedIndex&) = delete;

  // slot < kMaxKeyframes, not already in the index. kFull: not enough free postings (nothing
  // added); kInvalidInput: a bad slot or word.
  Status add(std::uint32_t slot, const BowVector& bow);
  // Takes the slot's postings out (bow: the vector it was added with).
  void remove(std::uint32_t slot, const BowVector& bow);
  // The best max_hits slots by score, best first, among those for which allowed(slot) is true
  // (e.g. not among the recent keyframes). Returns the count.
  template <typename Allowed>
  int query(const BowVector& q, Allowed allowed, IndexHit* hits, int max_hits) const;

  std::size_t postings_in_use() const { return in_use_; }
  static constexpr std::size_t kPostings = capacity::kMaxKeyframes * capacity::kMaxLoopFeaturesPerKeyframe;
  std::size_t footprint_bytes() const;

 private:
  struct Posting {
    std::uint32_t slot;
    float weight;
    std::int32_t next;  // next posting of the same word, or of the free list; -1: end
  };
  void accumulate(const BowVector& q) const;  // fills scores_ and touched_

  std::size_t words_;
  std::unique_ptr<std::int32_t[]> head_;       // per word
  std::unique_ptr<Posting[]> postings_;
  std::int32_t free_ = 0;
  std::size_t in_use_ = 0;
  mutable std::unique_ptr<float[]> scores_;    // per slot, for one query
  mutable std::unique_ptr<std::uint32_t[]> touched_;
  mutable std::unique_ptr<std::uint8_t[]> marked_;   // per slot: in touched_
  mutable std::size_t n_touched_ = 0;
};

template <typename Allowed>
int InvertedIndex::query(const BowVector& q, Allowed allowed, IndexHit* hits, int max_hits) const {
  accumulate(q);
  int n = 0;
  for (std::size_t t = 0; t < n_touched_; ++t) {
    const std::uint32_t slot = touched_[t];
    const IndexHit h{slot, 0.5f * scores_[slot]};
    scores_[slot] = 0.0f;
    marked_[slot] = 0;
    if (!allowed(slot)) continue;
    // Insertion into the sorted top list (max_hits is small).
    int i = n < max_hits ? n++ : max_hits;
    while (i > 0 && hits[i - 1].score < h.score) {
      if (i < max_hits) hits[i] = hits[i - 1];
      --i;
    }
    if (i < max_hits) hits[i] = h;
  }
  return n;
}

}  // namespace ums::loop
