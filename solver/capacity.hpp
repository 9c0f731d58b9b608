#pragma once
// Compile-time capacities of the solver. The solver sits below core/ (core -> solver), so it
// keeps its own capacities here instead of core/common/capacity.hpp; core chooses runtime sizes
// at or below these. One Problem is about 4.9 MB at these values (residual records 1 MB, landmark
// couplings 1 MB, four kMaxReducedDim^2 matrices 1.2 MB; docs/solver.md, "Memory"); create it once
// at start-up.

namespace ums::solver::capacity {

// Every parameter block of one problem: 11 poses + 11 speed-biases + 2 extrinsics + td + landmarks.
inline constexpr int kMaxParameterBlocks = 1100;
// Blocks eliminated by the Schur complement (landmarks: 1-dof inverse depths, up to 3-dof points).
inline constexpr int kMaxEliminatedBlocks = 1024;
inline constexpr int kMaxEliminatedTangentSize = 3;
// Blocks kept in the reduced ("camera") system and its dimension: 11 * 15 + 2 * 6 + 1 = 178.
inline constexpr int kMaxReducedBlocks = 48;
inline constexpr int kMaxReducedDim = 192;
// Largest block: speed-bias (9 ambient, 9 tangent); a pose is 7 ambient / 6 tangent.
inline constexpr int kMaxBlockAmbientSize = 9;
inline constexpr int kMaxBlockTangentSize = 9;
// Residual blocks (visual + IMU) and their shape: IMU is 15 rows; the widest visual factor touches
// pose_i, pose_j, two extrinsics, the inverse depth and td.
inline constexpr int kMaxResidualBlocks = 8192;
inline constexpr int kMaxResidualSize = 15;
inline constexpr int kMaxBlocksPerResidual = 6;
// Residual rows whose values a solve keeps for solved_residual(), per buffer (two: the iterate and
// the candidate): 2 per visual residual, 15 per IMU factor.
inline constexpr int kMaxKeptResidualRows = 16384;
// Reduced blocks one landmark may couple to (11 poses + 2 extrinsics + td, with spare).
inline constexpr int kMaxCouplingsPerLandmark = 24;
// Stored landmark-to-reduced couplings (doubles) over all landmarks: sum of d_B * e.
inline constexpr int kMaxCouplingEntries = 131072;
inline constexpr int kMaxCouplings = 16384;
// Dense priors attached to one problem, and the dimension marginalized at once (a frame is 15).
inline constexpr int kMaxPriors = 2;
inline constexpr int kMaxMarginalizedDim = 48;

}  // namespace ums::solver::capacity
