#include "core/loop/bow_vector.hpp"

#include <catch2/catch.hpp>

using namespace ums::loop;

TEST_CASE("bow_add keeps words sorted and sums repeats, L1 score is 1 for equal, 0 for disjoint", "[loop]") {
  BowVector a;
  REQUIRE(bow_add(&a, 7, 1.0f) == ums::Status::kOk);
  REQUIRE(bow_add(&a, 3, 1.0f) == ums::Status::kOk);
  REQUIRE(bow_add(&a, 7, 2.0f) == ums::Status::kOk);
  REQUIRE(a.size() == 2);
  CHECK(a[0].word == 3);
  CHECK(a[1].weight == 3.0f);
  bow_normalize_l1(&a);
  CHECK(a[0].weight == Approx(0.25));
  CHECK(bow_score(a, a) == Approx(1.0));
  BowVector b;
  bow_add(&b, 4, 1.0f);
  bow_normalize_l1(&b);
  CHECK(bow_score(a, b) == 0.0f);
  BowVector c;  // shares word 7 with weight 0.5 against 0.75: score = min = 0.5
  bow_add(&c, 7, 1.0f);
  bow_add(&c, 9, 1.0f);
  bow_normalize_l1(&c);
  CHECK(bow_score(a, c) == Approx(0.5));
  CHECK(bow_score(c, a) == Approx(0.5));
}

TEST_CASE("bow_add reports a full vector instead of growing", "[loop]") {
  BowVector v;
  for (std::uint32_t w = 0; w < BowVector::capacity(); ++w) REQUIRE(bow_add(&v, w, 1.0f) == ums::Status::kOk);
  CHECK(bow_add(&v, 100000, 1.0f) == ums::Status::kFull);
  CHECK(bow_add(&v, 5, 1.0f) == ums::Status::kOk);  // an existing word still adds
}
