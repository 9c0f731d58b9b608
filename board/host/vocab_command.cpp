// umsvins vocab train <dataset>... --out F [--k K] [--levels L] [--every N] [--features M] [--seed S]
//
// Trains the place-recognition vocabulary (core/loop/vocabulary.hpp) on recorded or simulated
// EuRoC-layout datasets: every N-th left image, its M strongest Shi-Tomasi corners (the front
// end's criterion) at least 15 px apart, described with BRIEF-256. Prints what it was trained on,
// so that the shipped file can say so.

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>

#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "core/common/capacity.hpp"
#include "core/loop/vocabulary.hpp"
#include "hal/replay/png_io.hpp"

namespace ums::cli {
namespace {

std::vector<std::string> left_images(const std::string& dataset) {
  const std::filesystem::path dir = std::filesystem::path(dataset) / "mav0" / "cam0" / "data";
  if (!std::filesystem::is_directory(dir)) throw std::runtime_error(dir.string() + ": no such folder (an EuRoC-layout dataset?)");
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".png") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<loop::Descriptor> describe_image(const std::string& path, int features, loop::BriefDescriber* brief,
                                             std::vector<std::uint8_t>* buffer) {
  int w = 0, h = 0;
  std::string error;
  if (!hal::read_png_gray8(path, buffer->data(), buffer->size(), &w, &h, &error)) throw std::runtime_error(error);
  const cv::Mat img(h, w, CV_8UC1, buffer->data());
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(img, corners, features, 0.01, 15.0);
  std::vector<loop::Descriptor> out;
  if (!brief->set_image(ImageView{buffer->data(), w, h, w})) throw std::runtime_error(path + ": image too large");
  for (const cv::Point2f& c : corners) {
    loop::Descriptor d;
    if (brief->describe(c.x, c.y, &d)) out.push_back(d);
  }
  return out;
}

}  // namespace

int run_vocab(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  if (argv.empty() || argv[0] != "train") throw UsageError("umsvins vocab: the only subcommand is 'train'");
  const Args args("vocab train", std::vector<std::string>(argv.begin() + 1, argv.end()), {},
                  {"out", "k", "levels", "every", "features", "seed"});
  if (args.positionals().empty()) throw UsageError("umsvins vocab train: give at least one <dataset>");
  const std::string out_path = args.require("out");
  loop::VocabularyParams params;
  params.k = static_cast<int>(args.get_long("k", params.k));
  params.levels = static_cast<int>(args.get_long("levels", params.levels));
  params.seed = static_cast<std::uint64_t>(args.get_long("seed", 1));
  const long every = args.get_long("every", 10);
  const long features = args.get_long("features", static_cast<long>(capacity::kMaxLoopFeaturesPerKeyframe));
  if (every < 1) throw UsageError("umsvins vocab train: --every must be >= 1");
  if (features < 1 || features > 2000) throw UsageError("umsvins vocab train: --features must be 1..2000");
  try {
    params.validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("umsvins vocab train: ") + e.what());
  }
  loop::BriefDescriber brief(capacity::kMaxImageWidth, capacity::kMaxImageHeight);
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(capacity::kMaxImageWidth) * capacity::kMaxImageHeight);
  std::vector<std::vector<loop::Descriptor>> images;
  std::size_t descriptors = 0;
  for (const std::string& dataset : args.positionals()) {
    const std::vector<std::string> files = left_images(dataset);
    std::size_t used = 0;
    for (std::size_t i = 0; i < files.size(); i += static_cast<std::size_t>(every), ++used) {
      images.push_back(describe_image(files[i], static_cast<int>(features), &brief, &buffer));
      descriptors += images.back().size();
    }
    out << "vocab: " << dataset << ": " << used << " of " << files.size() << " left images\n";
  }
  if (descriptors == 0) {
    err << "umsvins vocab train: no descriptors in the given images\n";
    return kExitFailure;
  }
  const loop::Vocabulary voc = loop::Vocabulary::train(images, params);
  const std::vector<std::uint8_t> bytes = voc.bytes();
  std::ofstream f(out_path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) throw std::runtime_error(out_path + ": cannot write");
  char crc[16];
  std::snprintf(crc, sizeof(crc), "%08x", voc.checksum());
  out << "vocab: " << images.size() << " images, " << descriptors << " descriptors; k " << params.k << ", levels "
      << params.levels << ", " << voc.words() << " words; " << bytes.size() << " bytes, checksum " << crc << " -> "
      << out_path << "\n";
  return kExitOk;
}

}  // namespace ums::cli
