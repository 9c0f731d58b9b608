#include "hal/d455/discovery.hpp"

#include <catch2/catch.hpp>

#include <linux/videodev2.h>

#include <filesystem>

#include "tests/common/test_paths.hpp"
#include "tests/hal/d455/fake_kernel.hpp"

using namespace ums::d455;

TEST_CASE("USB modalias parsing reads VID and PID", "[d455][discovery]") {
  unsigned vid = 0, pid = 0;
  REQUIRE(parse_usb_modalias("usb:v8086p0B5Cd5013dcEFdsc02dp01ic0Eisc01ip00in00", &vid, &pid));
  CHECK(vid == 0x8086);
  CHECK(pid == 0x0B5C);
  CHECK_FALSE(parse_usb_modalias("pci:v00008086d00001234", &vid, &pid));
  CHECK_FALSE(parse_usb_modalias("usb:vZZZZp0B5C", &vid, &pid));
}

TEST_CASE("Discovery finds the Y8I node, its metadata node and the D455's own IIO devices", "[d455][discovery]") {
  const std::string root = ums::test::make_temp_dir("d455_discovery");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel);
  SysFs fs(root);
  D455Nodes nodes;
  std::string error;
  REQUIRE(find_d455(fs, kernel, &nodes, &error));
  CHECK(nodes.video_path == "/dev/video2");   // video0 is depth (Z16), video2 offers Y8I
  CHECK(nodes.meta_path == "/dev/video3");    // the metadata node after it, same interface
  CHECK(nodes.usb_device == "/sys/devices/pci0000:00/0000:00:14.0/usb2/2-1");
  CHECK(nodes.accel_sysfs == "/sys/bus/iio/devices/iio:device0");
  CHECK(nodes.accel_dev == "/dev/iio:device0");
  CHECK(nodes.gyro_sysfs == "/sys/bus/iio/devices/iio:device1");  // not the laptop's iio:device2
  CHECK(nodes.gyro_dev == "/dev/iio:device1");
  CHECK(kernel.open_fds() == 0);  // every probe closed its descriptor
}

TEST_CASE("Discovery fails with a message when the only D455 node lacks Y8I (USB2 link)", "[d455][discovery]") {
  const std::string root = ums::test::make_temp_dir("d455_discovery_usb2");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel);
  kernel.video(root + "/dev/video2")->formats = {V4L2_PIX_FMT_GREY};
  SysFs fs(root);
  D455Nodes nodes;
  std::string error;
  REQUIRE_FALSE(find_d455(fs, kernel, &nodes, &error));
  CHECK(error.find("Y8I") != std::string::npos);
  CHECK(error.find("video2(d455 no Y8I)") != std::string::npos);
  CHECK(error.find("video6(v046Dp0825") != std::string::npos);  // the webcam was looked at and skipped

  const std::string empty = ums::test::make_temp_dir("d455_discovery_empty");
  REQUIRE_FALSE(find_d455(SysFs(empty), kernel, &nodes, &error));
  CHECK(error.find("seen: nothing") != std::string::npos);
}
