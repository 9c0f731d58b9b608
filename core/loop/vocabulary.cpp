#include "core/loop/vocabulary.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace ums::loop {
namespace {

constexpr char kMagic[8] = {'U', 'M', 'S', 'V', 'O', 'C', 'A', 'B'};
constexpr std::uint32_t kVersion = 1;

std::uint64_t next_random(std::uint64_t* s) {  // splitmix64
  std::uint64_t z = (*s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::size_t tree_nodes(int k, int levels) {
  std::size_t n = 1, level = 1;
  for (int l = 0; l < levels; ++l) {
    level *= static_cast<std::size_t>(k);
    n += level;
  }
  return n;
}

// The per-bit majority of the members (ties to 0): the binary median.
Descriptor majority(const std::vector<std::uint32_t>& members, const std::vector<Descriptor>& all) {
  int counts[256] = {};
  for (std::uint32_t m : members)
    for (int b = 0; b < 256; ++b) counts[b] += static_cast<int>((all[m][b >> 6] >> (b & 63)) & 1ULL);
  Descriptor d{0, 0, 0, 0};
  const int half = static_cast<int>(members.size());
  for (int b = 0; b < 256; ++b)
    if (2 * counts[b] > half) d[b >> 6] |= 1ULL << (b & 63);
  return d;
}

// k-means++: the first centre at random, each next one with probability proportional to the
// squared distance to the nearest centre chosen so far.
std::vector<Descriptor> seed_centres(const std::vector<std::uint32_t>& ids, const std::vector<Descriptor>& all,
                                     int k, std::uint64_t* rng) {
  std::vector<Descriptor> centres;
  centres.push_back(all[ids[next_random(rng) % ids.size()]]);
  std::vector<double> d2(ids.size(), 1e300);
  while (static_cast<int>(centres.size()) < k) {
    double total = 0.0;
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const double d = hamming(all[ids[i]], centres.back());
      d2[i] = std::min(d2[i], d * d);
      total += d2[i];
    }
    if (!(total > 0.0)) break;  // fewer distinct descriptors than k
    double pick = static_cast<double>(next_random(rng) >> 11) * (1.0 / 9007199254740992.0) * total;
    std::size_t chosen = 0;
    for (; chosen + 1 < ids.size(); ++chosen) {
      pick -= d2[chosen];
      if (pick <= 0.0) break;
    }
    centres.push_back(all[ids[chosen]]);
  }
  return centres;
}

void put_u32(std::vector<std::uint8_t>* out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

std::uint32_t get_u32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

}  // namespace

std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc) {
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (int b = 0; b < 8; ++b) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void VocabularyParams::validate() const {
  if (k < 2 || k > 32) throw std::invalid_argument("VocabularyParams.k = " + std::to_string(k) + ": allowed 2..32");
  if (levels < 1 || levels > 8)
    throw std::invalid_argument("VocabularyParams.levels = " + std::to_string(levels) + ": allowed 1..8");
  if (tree_nodes(k, levels) > capacity::kMaxVocabularyNodes)
    throw std::invalid_argument("VocabularyParams: k = " + std::to_string(k) + ", levels = " + std::to_string(levels) +
                                " needs " + std::to_string(tree_nodes(k, levels)) +
                                " nodes, over capacity::kMaxVocabularyNodes " +
                                std::to_string(capacity::kMaxVocabularyNodes));
  if (max_iterations < 1) throw std::invalid_argument("VocabularyParams.max_iterations must be >= 1");
}

Vocabulary Vocabulary::train(const std::vector<std::vector<Descriptor>>& images, const VocabularyParams& params) {
  params.validate();
  Vocabulary v;
  v.k_ = params.k;
  v.levels_ = params.levels;
  const std::size_t n = tree_nodes(params.k, params.levels);
  v.centres_.assign(n, Descriptor{0, 0, 0, 0});
  v.valid_.assign(n, 0);
  v.idf_.assign(n, 0.0f);
  std::vector<Descriptor> all;
  for (const auto& img : images) all.insert(all.end(), img.begin(), img.end());
  if (all.empty()) throw std::invalid_argument("Vocabulary::train: no descriptors");
  std::vector<std::uint32_t> ids(all.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<std::uint32_t>(i);
  v.valid_[0] = 1;
  std::uint64_t rng = params.seed;
  v.split(0, 0, ids, all, params, &rng);
  v.compute_idf(images);
  const std::vector<std::uint8_t> file = v.bytes();
  v.checksum_ = get_u32(file.data() + file.size() - 4);
  return v;
}

void Vocabulary::split(std::uint32_t node, int level, std::vector<std::uint32_t>& ids,
                       const std::vector<Descriptor>& all, const VocabularyParams& params, std::uint64_t* rng) {
  if (level == levels_ || ids.size() <= 1) return;  // a word
  const std::uint32_t first_child = node * static_cast<std::uint32_t>(k_) + 1;
  std::vector<Descriptor> centres;
  if (static_cast<int>(ids.size()) <= k_) {
    for (std::uint32_t i : ids) centres.push_back(all[i]);  // each descriptor its own child
  } else {
    centres = seed_centres(ids, all, k_, rng);
  }
  std::vector<std::vector<std::uint32_t>> members(centres.size());
  std::vector<int> assignment(ids.size(), -1);
  for (int it = 0; it < params.max_iterations; ++it) {
    bool changed = false;
    for (auto& m : members) m.clear();
    for (std::size_t i = 0; i < ids.size(); ++i) {
      int best = 0, best_d = 257;
      for (std::size_t c = 0; c < centres.size(); ++c) {
        const int d = hamming(all[ids[i]], centres[c]);
        if (d < best_d) best_d = d, best = static_cast<int>(c);
      }
      changed = changed || assignment[i] != best;
      assignment[i] = best;
      members[static_cast<std::size_t>(best)].push_back(ids[i]);
    }
    if (!changed || static_cast<int>(ids.size()) <= k_) break;
    for (std::size_t c = 0; c < centres.size(); ++c)
      if (!members[c].empty()) centres[c] = majority(members[c], all);
  }
  for (std::size_t c = 0; c < centres.size(); ++c) {
    if (members[c].empty()) continue;
    const std::uint32_t child = first_child + static_cast<std::uint32_t>(c);
    centres_[child] = centres[c];
    valid_[child] = 1;
    split(child, level + 1, members[c], all, params, rng);
  }
}

std::uint32_t Vocabulary::word_of(const Descriptor& d) const {
  std::uint32_t node = 0;
  for (int level = 0; level < levels_; ++level) {
    const std::uint32_t first = node * static_cast<std::uint32_t>(k_) + 1;
    int best_d = 257;
    std::uint32_t best = node;
    for (int c = 0; c < k_; ++c) {
      const std::uint32_t child = first + static_cast<std::uint32_t>(c);
      if (!valid_[child]) continue;
      const int dist = hamming(d, centres_[child]);
      if (dist < best_d) best_d = dist, best = child;
    }
    if (best == node) break;  // no children: a word above the last level
    node = best;
  }
  return node;
}

std::size_t Vocabulary::words() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < valid_.size(); ++i) n += idf_[i] > 0.0f ? 1 : 0;
  return n;
}

void Vocabulary::compute_idf(const std::vector<std::vector<Descriptor>>& images) {
  std::vector<std::uint32_t> images_with(centres_.size(), 0);
  std::vector<std::uint32_t> last_image(centres_.size(), 0xFFFFFFFFu);
  for (std::size_t i = 0; i < images.size(); ++i) {
    for (const Descriptor& d : images[i]) {
      const std::uint32_t w = word_of(d);
      if (last_image[w] == i) continue;
      last_image[w] = static_cast<std::uint32_t>(i);
      ++images_with[w];
    }
  }
  const double n = static_cast<double>(images.size());
  // A word every training image has carries no information (weight 0): it is kept as a word
  // with the smallest positive weight so that it still counts as a word.
  for (std::size_t w = 0; w < centres_.size(); ++w)
    if (images_with[w] > 0) idf_[w] = std::max(1e-6f, static_cast<float>(std::log(n / images_with[w])));
}

void Vocabulary::transform(const Descriptor* d, std::size_t n, BowVector* out, std::size_t* dropped) const {
  out->clear();
  std::size_t lost = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t w = word_of(d[i]);
    if (!(idf_[w] > 0.0f)) continue;
    if (bow_add(out, w, idf_[w]) != Status::kOk) ++lost;  // tf * idf: each occurrence adds idf
  }
  bow_normalize_l1(out);
  if (dropped != nullptr) *dropped = lost;
}

std::vector<std::uint8_t> Vocabulary::bytes() const {
  std::vector<std::uint8_t> out(kMagic, kMagic + 8);
  put_u32(&out, kVersion);
  put_u32(&out, static_cast<std::uint32_t>(k_));
  put_u32(&out, static_cast<std::uint32_t>(levels_));
  put_u32(&out, static_cast<std::uint32_t>(centres_.size()));
  out.insert(out.end(), valid_.begin(), valid_.end());
  for (const Descriptor& d : centres_)
    for (std::uint64_t word : d)
      for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(word >> (8 * i)));
  for (float f : idf_) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &f, 4);
    put_u32(&out, bits);
  }
  put_u32(&out, crc32(out.data(), out.size()));
  return out;
}

Vocabulary Vocabulary::parse(const std::vector<std::uint8_t>& b, const std::string& source) {
  auto fail = [&](const std::string& why) { return std::runtime_error(source + ": not a usable vocabulary: " + why); };
  if (b.size() < 28 || std::memcmp(b.data(), kMagic, 8) != 0) throw fail("no UMSVOCAB header");
  if (get_u32(&b[8]) != kVersion) throw fail("version " + std::to_string(get_u32(&b[8])) + ", this build reads 1");
  Vocabulary v;
  v.k_ = static_cast<int>(get_u32(&b[12]));
  v.levels_ = static_cast<int>(get_u32(&b[16]));
  const std::uint32_t n = get_u32(&b[20]);
  VocabularyParams p;
  p.k = v.k_;
  p.levels = v.levels_;
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    throw fail(e.what());
  }
  if (n != tree_nodes(v.k_, v.levels_)) throw fail("node count " + std::to_string(n) + " does not fit k and levels");
  const std::size_t want = 24 + static_cast<std::size_t>(n) * (1 + 32 + 4) + 4;
  if (b.size() != want)
    throw fail("size " + std::to_string(b.size()) + " bytes, expected " + std::to_string(want) + " (truncated?)");
  const std::uint32_t crc = get_u32(&b[want - 4]);
  if (crc32(b.data(), want - 4) != crc) throw fail("CRC mismatch (corrupted)");
  v.valid_.assign(b.begin() + 24, b.begin() + 24 + n);
  v.centres_.resize(n);
  std::size_t at = 24 + n;
  for (Descriptor& d : v.centres_)
    for (std::uint64_t& word : d) {
      word = 0;
      for (int i = 0; i < 8; ++i) word |= static_cast<std::uint64_t>(b[at++]) << (8 * i);
    }
  v.idf_.resize(n);
  for (float& x : v.idf_) {
    const std::uint32_t bits = get_u32(&b[at]);
    std::memcpy(&x, &bits, 4);
    at += 4;
  }
  v.checksum_ = crc;
  return v;
}

}  // namespace ums::loop
