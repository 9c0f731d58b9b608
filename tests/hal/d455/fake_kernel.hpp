#pragma once
// A fake kernel behind the Sys seam: V4L2 video and metadata nodes with mmap buffer queues, IIO
// character devices fed with raw bytes, and an unplug switch. Tests script frame production
// (produce_frame) and the HAL's real state machines consume it. Test-only code: allocates freely.

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "hal/d455/sys.hpp"

namespace ums::d455::test {

struct FakeFrameSpec {
  std::int64_t driver_ns = 0;       // v4l2 timestamp (monotonic)
  bool error_flag = false;          // V4L2_BUF_FLAG_ERROR
  int bytes_short = 0;              // bytesused = sizeimage - bytes_short
  bool with_meta = true;            // also produce a metadata buffer when the meta node streams
  std::uint32_t pts_us = 0;         // UVC PTS (device µs)
  std::uint32_t sensor_offset_us = 0;  // capture timing: PTS - this = mid exposure
  std::uint32_t frame_counter = 0;
  std::uint8_t emitter_mode = 0;
  std::int32_t sequence_override = -1;  // force a v4l2 sequence (reordering tests)
};

class FakeKernel : public Sys {
 public:
  struct Video {
    std::string path;
    bool meta = false;
    std::vector<std::uint32_t> formats;  // ENUM_FMT answers
    bool substitute_format = false;      // S_FMT answers YUYV instead of Y8I (USB2 link)
    std::vector<int> fps = {15, 30, 60, 90};
    int max_buffers = 8;
    // state
    std::uint32_t pixelformat = 0, width = 0, height = 0, bytesperline = 0, sizeimage = 0;
    std::uint32_t meta_format = 0;
    int fps_set = 0;
    std::vector<std::vector<std::uint8_t>> buffers;
    std::vector<int> queued;  // vectors with reserved room: the fake must not allocate per frame
    struct Done {
      int index;
      std::uint32_t bytesused, flags, sequence;
      std::int64_t t_ns;
    };
    std::vector<Done> done;
    bool streaming = false;
    std::uint32_t sequence = 0;
    std::uint64_t dropped_no_buffer = 0;
    int streamon_count = 0;
  };

  FakeKernel();
  // Nodes are registered by the exact path the HAL will open.
  Video& add_video(const std::string& path, std::vector<std::uint32_t> formats);
  Video& add_meta(const std::string& path, bool d4xx = true);
  void add_iio(const std::string& path);
  // Each push is returned by at most one read() (possibly cut to the read size).
  void push_iio(const std::string& path, const std::vector<std::uint8_t>& bytes);

  // One frame on the video node at `video_path`; left pixel (x,y) = (x + 3y + seed) & 255,
  // right = (5x + y + 2*seed) & 255. Returns false when no buffer was queued (frame lost).
  bool produce_frame(const std::string& video_path, int seed, const FakeFrameSpec& spec);
  static std::uint8_t left_pixel(int x, int y, int seed) { return static_cast<std::uint8_t>((x + 3 * y + seed) & 255); }
  static std::uint8_t right_pixel(int x, int y, int seed) { return static_cast<std::uint8_t>((5 * x + y + 2 * seed) & 255); }

  void unplug() { unplugged_ = true; }
  // Called at the start of every poll(), so a test can produce data as time passes.
  std::function<void(int poll_count)> on_poll;
  bool sleep_on_timeout = false;  // poll sleeps its timeout when nothing is ready

  Video* video(const std::string& path);
  std::map<int, std::vector<std::uint8_t>> xu_writes;  // selector -> last bytes written
  std::map<std::uint32_t, std::int32_t> ctrl_writes;  // V4L2 control id -> value
  bool refuse_xu = false;
  std::vector<std::uint8_t> hwm_request;  // last 1024-byte SET_CUR on selector 1 (HWM tunnel)
  std::vector<std::uint8_t> hwm_reply;    // what GET_CUR on selector 1 returns (1024 bytes)
  int open_fds() const { return static_cast<int>(fds_.size()); }
  int mapped() const { return mapped_; }
  int polls() const { return polls_; }

  int open(const char* path, int flags) override;
  int close(int fd) override;
  int ioctl(int fd, unsigned long request, void* arg) override;
  void* mmap(std::size_t length, int prot, int flags, int fd, off_t offset) override;
  int munmap(void* addr, std::size_t length) override;
  int poll(pollfd* fds, nfds_t nfds, int timeout_ms) override;
  ssize_t read(int fd, void* buf, std::size_t count) override;

 private:
  int video_ioctl(Video& v, unsigned long request, void* arg);
  std::map<std::string, Video> videos_;
  std::map<std::string, std::deque<std::vector<std::uint8_t>>> iio_;
  std::map<int, std::string> fds_;
  int next_fd_ = 100;
  int mapped_ = 0;
  int polls_ = 0;
  bool unplugged_ = false;
};

// Builds a D455-like sysfs tree under `root` (a fresh temp folder): the USB device, interface 0
// with video0 (depth, Z16), video1 (meta), video2 (IR, Y8I), video3 (meta); interface 3 with
// video4 (RGB) and video5 (meta); interface 5 with iio:device0 accel_3d and iio:device1 gyro_3d;
// plus an unrelated webcam (video6) and an unrelated accel_3d (iio:device2). Registers the
// matching fake nodes in `kernel` (paths prefixed with root). realbits: 16 or 32.
void build_d455_tree(const std::string& root, FakeKernel* kernel, int realbits = 16);

// One IIO scan record as the D455 produces it: s32 x, y, z at 0, 4, 8; s64 timestamp at 16.
std::vector<std::uint8_t> iio_record(std::int32_t x, std::int32_t y, std::int32_t z, std::int64_t ts);

}  // namespace ums::d455::test
