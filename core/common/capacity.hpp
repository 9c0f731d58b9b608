#pragma once
// Every compile-time capacity of the product, in one place. Runtime configuration may choose
// smaller values, never larger (each Options::validate() checks against these). Changing a value
// here changes the static memory footprint reported by `umsvins budget`.

#include <cstddef>

namespace ums::capacity {

// Images
inline constexpr int kMaxImageWidth = 1280;   // px, D455 IR max mode
inline constexpr int kMaxImageHeight = 800;   // px
inline constexpr int kMaxPyramidLevels = 4;   // the paper's 4-level 2D tracker
// px, repeated edge pixels around every pyramid level: the KLT reads a window by an edge in place
// (a tracked in-image point's reads reach at most 30 px left, 32 right and 31 below the image,
// windows up to 31 px; a 31 px window's 33 px template reads 41 columns from its origin)
inline constexpr int kPyramidMarginPx = 48;

// Front end
inline constexpr std::size_t kMaxFeaturesPerCamera = 400;  // VINS-Fusion max_cnt is 150-200
inline constexpr std::size_t kMaxFeatures = 2 * kMaxFeaturesPerCamera;

// Sliding window (VINS-Fusion WINDOW_SIZE = 10 -> 11 states incl. the newest)
inline constexpr std::size_t kWindowSize = 11;
inline constexpr std::size_t kMaxLandmarks = 600;             // tracked in the window
inline constexpr std::size_t kMaxObservationsPerLandmark = kWindowSize;

// IMU
inline constexpr std::size_t kMaxImuSamplesBetweenFrames = 512;  // 1 kHz IMU at 2 fps, bounded
inline constexpr std::size_t kImuRingSize = 2048;                // samples buffered ahead of frames

// Two cores (core/pipeline/backend_executor.hpp): back-end tasks waiting for the back end's
// thread, each one IMU sample or one frame. 256 is 1.3 s of a 200 Hz IMU, 0.25 s of 1 kHz.
inline constexpr std::size_t kBackendTasks = 256;

// Replay / HAL
inline constexpr std::size_t kMaxPathLength = 4096;  // bytes, file paths built at start-up

}  // namespace ums::capacity

// D455 HAL (hal/d455)
namespace ums::capacity {
inline constexpr int kD455MaxV4l2Buffers = 8;             // mmap buffers per node; LRS uses 4
inline constexpr std::size_t kD455MaxPendingMeta = 8;     // metadata buffers waiting for their frame
inline constexpr std::size_t kD455IioReadRecords = 64;    // IIO scan records read per read() call
inline constexpr std::size_t kD455MaxIioRecordBytes = 64; // one IIO scan record (D455: 24 bytes)
inline constexpr std::size_t kD455AccelHistory = 32;      // accel samples kept to bracket gyro stamps
inline constexpr std::size_t kD455GyroPending = 64;       // gyro samples waiting for a later accel
inline constexpr std::size_t kD455ImuOutRing = 256;       // fused samples waiting for the consumer
inline constexpr std::size_t kThreadBridgeEvents = 1024;   // live app: events between two threads (2.5 s of 400 Hz IMU)
inline constexpr std::size_t kThreadBridgeFrameSlots = 4;  // live app: stereo frames in flight between two threads
}  // namespace ums::capacity

// Front end (issue 6): corner candidates kept per detect() call (the strongest NMS maxima survive
// in a bounded heap; 4096 is ~10x what a 752x480 textured image yields above the threshold).
namespace ums::capacity {
inline constexpr std::size_t kMaxCornerCandidates = 4096;  // NMS maxima per detect() call
}  // namespace ums::capacity

// Estimator (issue 7)
namespace ums::capacity {
inline constexpr std::size_t kMaxVisualResiduals = 6000;   // bearing residuals in one window solve
inline constexpr std::size_t kStandstillImuSamples = 1024; // IMU samples kept for the standstill test (0.5 s at 2 kHz)
inline constexpr std::size_t kHeldImuSamples = 256;      // IMU samples held back for a negative camera-IMU offset (pipeline/time_aligner: 0.25 s at 1 kHz)
}  // namespace ums::capacity

// Loop closure (issue 17): the keyframe database and its place-recognition index.
namespace ums::capacity {
inline constexpr std::size_t kMaxKeyframes = 2000;             // keyframes in the database
inline constexpr std::size_t kMaxLoopFeaturesPerKeyframe = 300; // 3D features described per keyframe (paper: best 100-300)
inline constexpr std::size_t kMaxVocabularyNodes = 111111;      // a complete k=10, L=5 tree (k=10, L=4: 11111)
inline constexpr std::size_t kMaxLoopEdges = 500;              // loop edges in the 4-DoF pose graph (beside one odometry edge per keyframe)
inline constexpr std::size_t kMaxLoopEvents = 4096;            // accepted loops logged for loops.csv (the newest kept: over an hour at one a second)
inline constexpr std::size_t kLoopQueue = 8;                   // keyframes handed to the loop thread, the one it works on included (a pose-graph solve of ~200 ms is ~4 keyframes at 20 Hz)
}  // namespace ums::capacity
