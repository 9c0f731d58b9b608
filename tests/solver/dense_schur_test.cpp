#include "solver/dense_schur.hpp"

#include <catch2/catch.hpp>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

namespace ums::solver {
namespace {

// Random rows with full mantissas, zero before lo and in random gaps (a landmark's frames), and the
// reference: S(i, j) -= u_m(j) v_m(i) one row after the other, every column j < nf, rows i <= j.
struct Case {
  int nf = 0, n = 0;
  std::vector<std::vector<double>> v, u2;
  std::vector<int> lo;
  std::vector<std::uint64_t> groups;  // from the nonzeros of v: bit g, any in columns [4g, 4g + 4)
};

Case make_case(std::mt19937& rng, int nf, int n, bool runs = true) {
  std::uniform_real_distribution<double> val(-3.0, 3.0);
  std::uniform_int_distribution<int> first(0, nf > 0 ? nf - 1 : 0);
  std::bernoulli_distribution gap(0.15);
  Case c;
  c.nf = nf;
  c.n = n;
  for (int m = 0; m < n; ++m) {
    const double w = val(rng) / 7.0;
    std::vector<double> v(static_cast<std::size_t>(nf) + 1, 0.0), u2(2 * static_cast<std::size_t>(nf) + 2, 0.0);
    const int lo = m % 7 == 6 ? nf : first(rng);  // now and then a row with nothing (lo = nf)
    // Every other row has a run of 4..12 zeros after its first 4 (frames it was not seen in).
    const int run0 = runs && m % 2 == 0 ? lo + 4 : nf, run1 = run0 + 4 + (m % 9);
    for (int i = lo; i < nf; ++i) {
      if (gap(rng) || (i >= run0 && i < run1)) continue;
      v[static_cast<std::size_t>(i)] = val(rng) / 7.0;
      u2[2 * static_cast<std::size_t>(i)] = u2[2 * static_cast<std::size_t>(i) + 1] = w * v[static_cast<std::size_t>(i)];
    }
    c.v.push_back(v);
    c.u2.push_back(u2);
    c.lo.push_back(lo);
    std::uint64_t g = 0;
    for (int i = 0; i < nf; ++i)
      if (v[static_cast<std::size_t>(i)] != 0.0) g |= 1ULL << (i / 4);
    c.groups.push_back(g);
  }
  return c;
}

TEST_CASE("dense_schur_update gives the doubles of one row at a time, in row order", "[solver][dense_schur]") {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> val(-3.0, 3.0);
  int cases = 0;
  for (int nf : {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 22, 23, 36, 66, 72}) {
    for (int n : {0, 1, 2, 5, 31, 32, 33, 65}) {
      const Case c = make_case(rng, nf, n);
      const long ld = nf + 3;  // rows past the front: tail rows, must stay as they are
      std::vector<double> S(static_cast<std::size_t>(ld) * static_cast<std::size_t>(nf + 2));
      for (double& x : S) x = val(rng) / 7.0;
      std::vector<double> ref = S;
      for (int m = 0; m < n; ++m)
        for (int j = 0; j < nf; ++j)
          for (int i = 0; i <= j; ++i)
            ref[static_cast<std::size_t>(j * ld + i)] -= c.u2[static_cast<std::size_t>(m)][2 * static_cast<std::size_t>(j)] *
                                                         c.v[static_cast<std::size_t>(m)][static_cast<std::size_t>(i)];
      std::vector<const double*> v, u2;
      for (int m = 0; m < n; ++m) {
        v.push_back(c.v[static_cast<std::size_t>(m)].data());
        u2.push_back(c.u2[static_cast<std::size_t>(m)].data());
      }
      std::vector<double> S_grouped = S;
      dense_schur_update(S.data(), ld, nf, DenseSchurRows{n, v.data(), u2.data(), c.lo.data()});
      dense_schur_update(S_grouped.data(), ld, nf, DenseSchurRows{n, v.data(), u2.data(), c.lo.data(), c.groups.data()});
      bool upper_equal = true, outside_untouched = true, grouped_equal = true;
      for (int j = 0; j < nf + 2; ++j)
        for (int i = 0; i < ld; ++i) {
          const std::size_t k = static_cast<std::size_t>(j * ld + i);
          const bool upper = j < nf && i <= j;
          const bool front_lower = j < nf && i > j && i < nf;  // may be written (never read)
          if (upper) upper_equal = upper_equal && std::memcmp(&S[k], &ref[k], sizeof(double)) == 0;
          if (upper) grouped_equal = grouped_equal && std::memcmp(&S_grouped[k], &ref[k], sizeof(double)) == 0;
          if (!upper && !front_lower) outside_untouched = outside_untouched && S_grouped[k] == ref[k];
          if (!upper && !front_lower) outside_untouched = outside_untouched && S[k] == ref[k];
        }
      INFO("front " << nf << ", rows " << n);
      CHECK(upper_equal);        // bit for bit, the sign of zeros included
      CHECK(grouped_equal);      // rows left out of the tiles they are zero over: the same bits
      CHECK(outside_untouched);  // tail columns and rows past the front
      ++cases;
    }
  }
  CHECK(cases == 17 * 8);
}

TEST_CASE("dense_schur_update: rows out of order give other doubles (the test can tell)", "[solver][dense_schur]") {
  std::mt19937 rng(3);
  const int nf = 24, n = 9;
  Case c = make_case(rng, nf, n, false);
  for (int& lo : c.lo) lo = 0;
  for (int m = 0; m < n; ++m)
    for (int i = 0; i < nf; ++i)
      if (c.v[static_cast<std::size_t>(m)][static_cast<std::size_t>(i)] == 0.0) c.v[static_cast<std::size_t>(m)][static_cast<std::size_t>(i)] = 0.25;
  std::vector<const double*> v, u2, v_rev, u2_rev;
  for (int m = 0; m < n; ++m) {
    v.push_back(c.v[static_cast<std::size_t>(m)].data());
    u2.push_back(c.u2[static_cast<std::size_t>(m)].data());
    v_rev.push_back(c.v[static_cast<std::size_t>(n - 1 - m)].data());
    u2_rev.push_back(c.u2[static_cast<std::size_t>(n - 1 - m)].data());
  }
  std::vector<double> S(static_cast<std::size_t>(nf * nf), 1.0 / 3.0), T = S;
  dense_schur_update(S.data(), nf, nf, DenseSchurRows{n, v.data(), u2.data(), c.lo.data()});
  dense_schur_update(T.data(), nf, nf, DenseSchurRows{n, v_rev.data(), u2_rev.data(), c.lo.data()});
  int differ = 0;
  for (int j = 0; j < nf; ++j)
    for (int i = 0; i <= j; ++i) differ += S[static_cast<std::size_t>(j * nf + i)] != T[static_cast<std::size_t>(j * nf + i)];
  CHECK(differ > 10);
}

TEST_CASE("dense_schur_groups marks the groups of 4 columns a run of nonzeros reaches", "[solver][dense_schur]") {
  CHECK(dense_schur_groups(0, 0) == 0ULL);
  CHECK(dense_schur_groups(5, 5) == 0ULL);
  CHECK(dense_schur_groups(0, 1) == 0x1ULL);
  CHECK(dense_schur_groups(3, 5) == 0x3ULL);   // columns 3, 4: groups 0 and 1
  CHECK(dense_schur_groups(4, 8) == 0x2ULL);   // exactly group 1
  CHECK(dense_schur_groups(6, 18) == 0x1EULL); // groups 1..4
  CHECK(dense_schur_groups(250, 256) == (3ULL << 62));
  CHECK(dense_schur_groups(0, 256) == ~0ULL);
}

}  // namespace
}  // namespace ums::solver
