#include "solver/double_pair.hpp"

#include <catch2/catch.hpp>
#include <algorithm>
#include <limits>
#include <random>
#include <vector>

namespace ums::solver {
namespace {

// Values with full mantissas, so that any change of operation order shows in the last bits.
std::vector<double> random_values(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::vector<double> v(static_cast<std::size_t>(n));
  for (double& x : v) x = u(rng) / 7.0;
  return v;
}

TEST_CASE("sub_scaled_sum gives the doubles of one scalar pass per term", "[solver][double_pair]") {
  std::mt19937 rng(7);
  int cases = 0;
  for (int m = 1; m <= 4; ++m) {
    for (int n = 1; n <= 13; ++n) {
      std::vector<double> xs[4];
      const double* x[4];
      for (int k = 0; k < m; ++k) {
        xs[k] = random_values(rng, n);
        x[k] = xs[k].data();
      }
      const std::vector<double> c = random_values(rng, m);
      // One guard element past n: the kernel must not touch it.
      std::vector<double> y = random_values(rng, n + 1);
      std::vector<double> ref = y;
      for (int k = 0; k < m; ++k)
        for (int i = 0; i < n; ++i) ref[i] -= c[k] * x[k][i];
      sub_scaled_sum(y.data(), m, c.data(), x, n);
      for (int i = 0; i <= n; ++i) REQUIRE(y[i] == ref[i]);  // bit-equal, guard unchanged
      ++cases;
    }
  }
  CHECK(cases == 52);
}

TEST_CASE("add_jtj_any gives the doubles of the row-ordered dot products", "[solver][double_pair]") {
  std::mt19937 rng(11);
  const long ld = 12;
  for (int rows : {1, 2, 3, 15}) {
    for (int ta : {1, 3, 6, 9}) {
      for (int tb : {1, 6, 9}) {
        const std::vector<double> A = random_values(rng, rows * ta);
        const std::vector<double> B = random_values(rng, rows * tb);
        std::vector<double> H = random_values(rng, static_cast<int>(ld) * tb);
        std::vector<double> ref = H;
        for (int j = 0; j < tb; ++j)
          for (int i = 0; i < ta; ++i) {
            double s = A[i] * B[j];
            for (int r = 1; r < rows; ++r) s += A[r * ta + i] * B[r * tb + j];
            ref[j * ld + i] += s;
          }
        add_jtj_any(H.data(), ld, A.data(), ta, B.data(), tb, rows);
        for (std::size_t k = 0; k < H.size(); ++k) REQUIRE(H[k] == ref[k]);  // rows past ta unchanged too
      }
    }
  }
  // The value itself: [1 2; 3 4]^T [5; 6] = [23; 34].
  const double A[4] = {1.0, 2.0, 3.0, 4.0}, B[2] = {5.0, 6.0};
  double h[2] = {0.5, -0.5};
  add_jtj_any(h, 2, A, 2, B, 1, 2);
  CHECK(h[0] == 23.5);
  CHECK(h[1] == 33.5);
}

TEST_CASE("add_jtj_rows: rows holding a zero factor and the lower triangle left out, the same doubles",
          "[solver][double_pair]") {
  std::mt19937 rng(13);
  const long ld = 10;
  const int rows = 15;
  int skipped = 0;
  for (int ta : {6, 9}) {
    for (const bool upper : {false, true}) {
      const int tb = upper ? ta : 9;
      // A zero outside rows [2, 11), B outside [5, 15): the products live on [5, 11).
      std::vector<double> A = random_values(rng, rows * ta);
      std::vector<double> B = upper ? A : random_values(rng, rows * tb);
      for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < ta; ++c)
          if (r < 2 || r >= 11) A[r * ta + c] = 0.0;
        for (int c = 0; c < tb; ++c)
          if (!upper && r < 5) B[r * tb + c] = 0.0;
      }
      if (upper) B = A;
      int a0 = -1, a1 = -1, b0 = -1, b1 = -1;
      nonzero_rows(A.data(), rows, ta, &a0, &a1);
      nonzero_rows(B.data(), rows, tb, &b0, &b1);
      CHECK(a0 == 2);
      CHECK(a1 == 11);
      CHECK(b0 == (upper ? 2 : 5));
      CHECK(b1 == (upper ? 11 : 15));
      std::vector<double> H = random_values(rng, static_cast<int>(ld) * tb);
      std::vector<double> ref = H;
      add_jtj_any(ref.data(), ld, A.data(), ta, B.data(), tb, rows);
      add_jtj_rows(H.data(), ld, A.data(), ta, B.data(), tb, std::max(a0, b0), std::min(a1, b1), upper);
      for (int j = 0; j < tb; ++j)
        for (int i = 0; i < ld; ++i) {
          const std::size_t k = static_cast<std::size_t>(j * ld + i);
          if (i < ta && (!upper || i <= j)) {
            REQUIRE(H[k] == ref[k]);
          } else if (i >= ta) {
            REQUIRE(H[k] == ref[k]);  // past the block: untouched by both
          } else {
            ++skipped;  // below the diagonal of a diagonal block: never read
          }
        }
    }
  }
  CHECK(skipped > 0);
  // All-zero and NaN rows: an empty range adds nothing; a NaN row counts as non-zero.
  double J[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  int r0 = -1, r1 = -1;
  nonzero_rows(J, 3, 2, &r0, &r1);
  CHECK(r0 == r1);
  J[3] = std::numeric_limits<double>::quiet_NaN();
  nonzero_rows(J, 3, 2, &r0, &r1);
  CHECK(r0 == 1);
  CHECK(r1 == 2);
  double h = 1.5;
  add_jtj_rows(&h, 1, J, 1, J, 1, 2, 2, false);
  CHECK(h == 1.5);
}


TEST_CASE("add_jtj_2x6 and col_update3 give the doubles of the per-entry formulas", "[solver][double_pair]") {
  std::mt19937 rng(19);
  const long ld = 9;  // columns apart by more than 6, and an odd stride
  for (int trial = 0; trial < 20; ++trial) {
    const std::vector<double> A = random_values(rng, 12), C = random_values(rng, 12);
    for (bool upper : {true, false}) {
      std::vector<double> H = random_values(rng, static_cast<int>(ld) * 6);
      std::vector<double> ref = H;
      const std::vector<double>& B = upper ? A : C;
      for (int j = 0; j < 6; ++j)
        for (int i = 0; i < (upper ? j + 1 : 6); ++i) ref[j * ld + i] += A[i] * B[j] + A[6 + i] * B[6 + j];
      if (upper)
        add_jtj_2x6<true>(H.data(), ld, A.data(), A.data());
      else
        add_jtj_2x6<false>(H.data(), ld, A.data(), C.data());
      for (int j = 0; j < 6; ++j)
        for (int i = 0; i < (upper ? j + 1 : static_cast<int>(ld)); ++i) REQUIRE(H[j * ld + i] == ref[j * ld + i]);
    }
    // col[0..6) += a0 b0 + a1 b1 + a2 b2, the element after it untouched.
    const std::vector<double> a = random_values(rng, 18), b = random_values(rng, 3);
    Pair p[3][3];
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 3; ++i) p[k][i] = load_pair(a.data() + 6 * k + 2 * i);
    std::vector<double> col = random_values(rng, 7);
    std::vector<double> ref = col;
    for (int i = 0; i < 6; ++i) ref[i] += a[i] * b[0] + a[6 + i] * b[1] + a[12 + i] * b[2];
    col_update3<6>(col.data(), p[0], p[1], p[2], b[0], b[1], b[2]);
    for (int i = 0; i < 7; ++i) REQUIRE(col[i] == ref[i]);
  }
  double z[19];
  std::fill(z, z + 19, 1.0);
  zero_doubles<18>(z);
  CHECK(std::count(z, z + 18, 0.0) == 18);
  CHECK(z[18] == 1.0);
}

}  // namespace
}  // namespace ums::solver
