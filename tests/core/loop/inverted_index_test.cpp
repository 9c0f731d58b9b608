#include "core/loop/inverted_index.hpp"

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"

using namespace ums;
using namespace ums::loop;

namespace {

BowVector bow(std::initializer_list<std::pair<std::uint32_t, float>> words) {
  BowVector v;
  for (const auto& w : words) bow_add(&v, w.first, w.second);
  bow_normalize_l1(&v);
  return v;
}

}  // namespace

TEST_CASE("InvertedIndex: the query's scores equal bow_score, best first, excluded slots never returned", "[loop]") {
  InvertedIndex index(100);
  const BowVector a = bow({{1, 1}, {2, 1}, {3, 2}});
  const BowVector b = bow({{3, 1}, {4, 1}});
  const BowVector c = bow({{50, 1}});
  REQUIRE(index.add(10, a) == Status::kOk);
  REQUIRE(index.add(11, b) == Status::kOk);
  REQUIRE(index.add(12, c) == Status::kOk);
  CHECK(index.postings_in_use() == 6);
  IndexHit hits[4];
  AllocScope scope;
  int n = index.query(a, [](std::uint32_t) { return true; }, hits, 4);
  CHECK(scope.allocations() == 0);
  REQUIRE(n == 2);  // c shares no word with a
  CHECK(hits[0].keyframe == 10);
  CHECK(hits[0].score == Approx(1.0));
  CHECK(hits[1].keyframe == 11);
  CHECK(hits[1].score == Approx(bow_score(a, b)));
  n = index.query(a, [](std::uint32_t slot) { return slot != 10; }, hits, 4);
  REQUIRE(n == 1);
  CHECK(hits[0].keyframe == 11);
  // A second query starts from zero scores.
  n = index.query(a, [](std::uint32_t) { return true; }, hits, 1);
  REQUIRE(n == 1);
  CHECK(hits[0].score == Approx(1.0));
}

TEST_CASE("InvertedIndex: removal frees the postings for reuse, bad slots and words refused", "[loop]") {
  InvertedIndex index(10);
  const BowVector a = bow({{1, 1}, {2, 1}});
  REQUIRE(index.add(0, a) == Status::kOk);
  index.remove(0, a);
  CHECK(index.postings_in_use() == 0);
  IndexHit hits[2];
  CHECK(index.query(a, [](std::uint32_t) { return true; }, hits, 2) == 0);
  CHECK(index.add(capacity::kMaxKeyframes, a) == Status::kInvalidInput);
  CHECK(index.add(1, bow({{10, 1}})) == Status::kInvalidInput);  // word 10 of a 10-word index
  // Fill every posting: the next keyframe is refused whole.
  BowVector full;
  for (std::uint32_t w = 0; w < 10; ++w) bow_add(&full, w, 1.0f);
  std::uint32_t slot = 0;
  while (index.postings_in_use() + full.size() <= InvertedIndex::kPostings) REQUIRE(index.add(slot++ % 2000, full) == Status::kOk);
  CHECK(index.add(5, full) == Status::kFull);
}
