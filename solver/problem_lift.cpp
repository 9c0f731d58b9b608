// Landmarks seen through a point (residual.hpp, PointLift; docs/solver.md, "Landmarks seen through
// a point"). A lifted residual's Jacobians with respect to its landmark's host block and the
// landmark itself are A * G_h and A * g, with A = d r / d p its own (2 x 3) and G = [G_h | g] =
// d p / d (host, landmark) shared by the landmark's residuals. Per residual the solver sums
//   S += A^T A,  s += A^T r,  X_c += A^T J_c  (every other variable block c),
// and the blocks of the other variables as usual; once per landmark it forms
//   H_hh += G_h^T S G_h,  b_h += G_h^T s,  H_hc += G_h^T X_c,
//   H_ll += g^T S g,  g_l += g^T s,  V_h += G_h^T S g,  V_c += X_c^T g,
// which are the sums of the per-residual products A G, regrouped: equal up to rounding.
#include <algorithm>

#include "solver/double_pair.hpp"
#include "solver/problem.hpp"

namespace ums::solver {

namespace {

constexpr int kG = 7;  // columns of G: the 6-dof host, the 1-dof landmark

}  // namespace

void Problem::begin_lift(int l) {
  std::fill(lift_s_, lift_s_ + 3, 0.0);
  lift_host_slot_ = -1;
  if (gradient_pass_) return;  // s alone: S and X are not read (zeroed by the next whole pass)
  std::fill(lift_S_, lift_S_ + 9, 0.0);
  const int n = lm_cpl_begin_[l + 1] - lm_cpl_begin_[l];
  for (int i = 0; i < n; ++i) {
    lift_used_[i] = false;
    zero_doubles<18>(lift_X_[i]);
  }
}

// S += A^T A (its upper triangle), s += A^T r, each entry A[k] A[m] + A[3 + k] A[3 + m] (and
// A[k] r0 + A[3 + k] r1) added to the sum. The pairs are loaded from the workspace itself: GCC
// paired the entries of a local copy of A through the stack, two 8-byte stores read back as one
// 16-byte load, which the store buffer cannot forward (a fifth of the function's time).
void Problem::add_lift_sums(const double* A, double r0, double r1) {
  const Pair a01 = load_pair(A), a12 = load_pair(A + 1), a34 = load_pair(A + 3), a45 = load_pair(A + 4);
  const Pair a0 = {A[0], A[0]}, a1 = {A[1], A[1]}, a3 = {A[3], A[3]}, a4 = {A[4], A[4]};
  store_pair(lift_S_, load_pair(lift_S_) + (a0 * a01 + a3 * a34));      // S00, S01
  lift_S_[2] += A[0] * A[2] + A[3] * A[5];                               // S02
  store_pair(lift_S_ + 4, load_pair(lift_S_ + 4) + (a1 * a12 + a4 * a45));  // S11, S12
  lift_S_[8] += A[2] * A[2] + A[5] * A[5];                               // S22
  store_pair(lift_s_, load_pair(lift_s_) + (a01 * Pair{r0, r0} + a34 * Pair{r1, r1}));
  lift_s_[2] += A[2] * r0 + A[5] * r1;
}

// One lifted residual: A = d r / d p in its host's Jacobian slot; its other blocks are 6-dof
// (fast2) and 2 rows.
void Problem::accumulate_lifted(const Residual& rb, const double* r) {
  // A in locals first: the sums are members like the workspace A sits in, so the compiler
  // reloaded A after every store.
  const double* Aw = jac_ws_[rb.lift_pos];  // 2 x 3 row-major
  const double A[6] = {Aw[0], Aw[1], Aw[2], Aw[3], Aw[4], Aw[5]};
  const double r0 = r[0], r1 = r[1];
  add_lift_sums(Aw, r0, r1);
  lift_host_slot_ = rb.slot[rb.lift_pos];
  if (mark_touched_) touched_[rb.blocks[rb.lift_pos]] = true;
  const int base = lm_cpl_begin_[rb.landmark];
  for (int a = 0; a < rb.num_sorted; ++a) {
    const int ka = rb.sorted[a];
    if (ka == rb.lift_pos) continue;
    if (mark_touched_) touched_[rb.blocks[ka]] = true;
    add_blocks_2x6(rb, a, r, rb.lift_pos);
    const double* Ja = jac_ws_[ka];
    Pair j0[3], j1[3];
    for (int i = 0; i < 3; ++i) {
      j0[i] = load_pair(Ja + 2 * i);
      j1[i] = load_pair(Ja + 6 + 2 * i);
    }
    const int local = rb.slot[ka] - base;
    lift_used_[local] = true;
    double* X = lift_X_[local];
    for (int k = 0; k < 3; ++k) col_update2<6>(X + 6 * k, j0, j1, A[k], A[3 + k]);
  }
}

// The host and landmark terms of landmark l from its sums and G. false: the lift failed.
bool Problem::lift_jacobian(int l, double* G) {
  const LiftRef& lr = lifts_[lm_lift_[l]];
  const double* xs[capacity::kMaxBlocksPerResidual];
  for (int i = 0; i < lr.num_blocks; ++i) xs[i] = blocks_[lr.blocks[i]].x;
  return lr.fn->evaluate(xs, G);
}

bool Problem::finish_lift(int l) {
  if (lift_host_slot_ < 0) return true;  // no residual of l was lifted: nothing to form
  const LiftRef& lr = lifts_[lm_lift_[l]];
  double G[3 * kG];
  if (!lift_jacobian(l, G)) return false;
  double S[9];
  for (int k = 0; k < 3; ++k)
    for (int m = 0; m < 3; ++m) S[3 * k + m] = k <= m ? lift_S_[3 * k + m] : lift_S_[3 * m + k];
  // T = S G_h (3 x 6), Sg = S g.
  double T[18], Sg[3];
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 6; ++j) T[6 * k + j] = S[3 * k] * G[j] + S[3 * k + 1] * G[kG + j] + S[3 * k + 2] * G[2 * kG + j];
    Sg[k] = S[3 * k] * G[6] + S[3 * k + 1] * G[kG + 6] + S[3 * k + 2] * G[2 * kG + 6];
  }
  MatrixMap H = acc_H_->m();
  const Eigen::Index ld = H.outerStride();
  const int oh = blocks_[lr.blocks[0]].index;
  double* vh = v_ + cpl_v_[lift_host_slot_];
  for (int i = 0; i < 6; ++i) {
    const double g0 = G[i], g1 = G[kG + i], g2 = G[2 * kG + i];
    for (int j = i; j < 6; ++j) H.data()[(oh + j) * ld + oh + i] += g0 * T[j] + g1 * T[6 + j] + g2 * T[12 + j];
    (*acc_b_)[oh + i] += g0 * lift_s_[0] + g1 * lift_s_[1] + g2 * lift_s_[2];
    vh[i] += g0 * Sg[0] + g1 * Sg[1] + g2 * Sg[2];
  }
  const double g[3] = {G[6], G[kG + 6], G[2 * kG + 6]};
  Hll_[l][0] += g[0] * Sg[0] + g[1] * Sg[1] + g[2] * Sg[2];
  gl_[l][0] += g[0] * lift_s_[0] + g[1] * lift_s_[1] + g[2] * lift_s_[2];
  add_lift_couplings(l, G);
  return true;
}

// b_h += G_h^T s, g_l += g^T s: the gradient terms of finish_lift, in its order.
bool Problem::finish_lift_gradient(int l) {
  if (lift_host_slot_ < 0) return true;
  double G[3 * kG];
  if (!lift_jacobian(l, G)) return false;
  const int oh = blocks_[lifts_[lm_lift_[l]].blocks[0]].index;
  for (int i = 0; i < 6; ++i) (*acc_b_)[oh + i] += G[i] * lift_s_[0] + G[kG + i] * lift_s_[1] + G[2 * kG + i] * lift_s_[2];
  gl_[l][0] += G[6] * lift_s_[0] + G[kG + 6] * lift_s_[1] + G[2 * kG + 6] * lift_s_[2];
  return true;
}

// H_hc += G_h^T X_c (or its transpose below the diagonal) and V_c += X_c^T g for every other
// block c the landmark's lifted residuals reached. Column by column in packets: above the
// diagonal a column of the block is G_h^T times a column of X_c (G's rows as packets), below it
// X_c^T times a column of G_h (X_c's rows as packets).
void Problem::add_lift_couplings(int l, const double* G) {
  MatrixMap H = acc_H_->m();
  const Eigen::Index ld = H.outerStride();
  const int oh = blocks_[lifts_[lm_lift_[l]].blocks[0]].index;
  const int base = lm_cpl_begin_[l];
  const int n = lm_cpl_begin_[l + 1] - base;
  Pair g[3][3];  // G_h's rows as packets
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 3; ++i) g[k][i] = Pair{G[kG * k + 2 * i], G[kG * k + 2 * i + 1]};
  for (int c = 0; c < n; ++c) {
    if (!lift_used_[c]) continue;
    const double* X = lift_X_[c];
    const int oc = cpl_row_[base + c];
    double* v = v_ + cpl_v_[base + c];
    for (int j = 0; j < 6; ++j) v[j] += X[j] * G[6] + X[6 + j] * G[kG + 6] + X[12 + j] * G[2 * kG + 6];
    if (oh < oc) {
      for (int j = 0; j < 6; ++j)
        col_update3<6>(H.data() + (oc + j) * ld + oh, g[0], g[1], g[2], X[j], X[6 + j], X[12 + j]);
    } else {
      Pair x[3][3];
      for (int k = 0; k < 3; ++k)
        for (int i = 0; i < 3; ++i) x[k][i] = load_pair(X + 6 * k + 2 * i);
      for (int i = 0; i < 6; ++i)
        col_update3<6>(H.data() + (oh + i) * ld + oc, x[0], x[1], x[2], G[i], G[kG + i], G[2 * kG + i]);
    }
  }
}

}  // namespace ums::solver
