#pragma once
// A place-recognition vocabulary for BRIEF-256 descriptors: a k-ary tree of L levels, stored
// flat (node n's children are n*k+1 .. n*k+k; a complete k=10, L=4 tree is 11 111 nodes, 355 KB
// with its weights), trained by the product itself (`umsvins vocab train`) the way DBoW2's
// trainer does: hierarchical k-medians, k-means++ seeding, the per-bit majority as a cluster's
// centre; each leaf is a word with its IDF weight log(N / N_w) over the N training images.
//
// Loaded once at start-up (the only allocation); looking up words and building a keyframe's
// bag of words allocate nothing. The file is versioned and carries a CRC-32, which is also the
// vocabulary's checksum that map files record.

#include <cstdint>
#include <string>
#include <vector>

#include "core/loop/bow_vector.hpp"
#include "core/loop/brief.hpp"

namespace ums::loop {

struct VocabularyParams {
  int k = 10;       // branching factor
  int levels = 4;   // depth: up to k^levels words
  int max_iterations = 10;  // k-medians iterations per split
  std::uint64_t seed = 1;   // k-means++ seeding
  void validate() const;    // std::invalid_argument naming the field; nodes within capacity
};

class Vocabulary {
 public:
  Vocabulary() = default;

  // Offline: one vector of descriptors per training image. Allocates; not for the frame path.
  static Vocabulary train(const std::vector<std::vector<Descriptor>>& images, const VocabularyParams& params);

  // The word (leaf node index) a descriptor falls into.
  std::uint32_t word_of(const Descriptor& d) const;
  // TF-IDF bag of words of one keyframe's descriptors, L1-normalised. Words beyond the vector's
  // capacity are counted in *dropped (may be null).
  void transform(const Descriptor* d, std::size_t n, BowVector* out, std::size_t* dropped = nullptr) const;

  int k() const { return k_; }
  int levels() const { return levels_; }
  std::size_t nodes() const { return centres_.size(); }
  std::size_t words() const;
  float idf(std::uint32_t word) const { return idf_[word]; }
  bool empty() const { return centres_.empty(); }
  std::uint32_t checksum() const { return checksum_; }

  // The versioned binary file's bytes (magic, version, k, levels, node count, valid flags,
  // centres, weights, CRC-32); reading and writing the file is the board's (no I/O in core).
  std::vector<std::uint8_t> bytes() const;
  // Parses bytes(); throws std::runtime_error "<source>: not a usable vocabulary: <why>" (magic,
  // version, sizes, capacity, CRC, truncation).
  static Vocabulary parse(const std::vector<std::uint8_t>& bytes, const std::string& source);

 private:
  void split(std::uint32_t node, int level, std::vector<std::uint32_t>& ids,
             const std::vector<Descriptor>& all, const VocabularyParams& params, std::uint64_t* rng);
  void compute_idf(const std::vector<std::vector<Descriptor>>& images);

  int k_ = 0;
  int levels_ = 0;
  std::vector<Descriptor> centres_;
  std::vector<std::uint8_t> valid_;  // 1: the node exists
  std::vector<float> idf_;           // per node; non-zero at words only
  std::uint32_t checksum_ = 0;
};

// CRC-32 (IEEE 802.3, reflected 0xEDB88320) of bytes: files' integrity checks.
std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc = 0);

}  // namespace ums::loop
