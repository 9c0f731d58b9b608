// The vocabulary trainer on descriptors of known structure, and the file round trip and its
// refusals. (The micro sequence is a standstill: every frame sees the same place, so place
// recognition is measured on the simulated flights with loop closure, not here.)
#include "core/loop/vocabulary.hpp"

#include <catch2/catch.hpp>


using namespace ums;
using namespace ums::loop;

namespace {

std::uint64_t rnd(std::uint64_t* s) {
  *s ^= *s << 13;
  *s ^= *s >> 7;
  *s ^= *s << 17;
  return *s;
}

Descriptor random_descriptor(std::uint64_t* s) { return {rnd(s), rnd(s), rnd(s), rnd(s)}; }

Descriptor flip_bits(Descriptor d, int n, std::uint64_t* s) {
  for (int i = 0; i < n; ++i) {
    const int b = static_cast<int>(rnd(s) % 256);
    d[b >> 6] ^= 1ULL << (b & 63);
  }
  return d;
}

// 60 places, each an image of 40 descriptors: 40 fixed "landmarks" of that place seen with 10 of
// 256 bits of noise.
std::vector<std::vector<Descriptor>> places(int n_places, std::uint64_t seed, std::vector<std::vector<Descriptor>>* truth) {
  std::uint64_t s = seed;
  truth->assign(n_places, {});
  std::vector<std::vector<Descriptor>> images(n_places);
  for (int p = 0; p < n_places; ++p)
    for (int i = 0; i < 40; ++i) {
      (*truth)[p].push_back(random_descriptor(&s));
      images[p].push_back(flip_bits((*truth)[p].back(), 10, &s));
    }
  return images;
}

}  // namespace

TEST_CASE("Vocabulary: noisy views of a place land on that place's words, other places score low", "[loop]") {
  std::vector<std::vector<Descriptor>> truth;
  const auto images = places(60, 42, &truth);
  VocabularyParams p;
  p.k = 8;
  p.levels = 3;  // 512 leaves for 2400 training descriptors
  const Vocabulary voc = Vocabulary::train(images, p);
  CHECK(voc.nodes() == 1 + 8 + 64 + 512);
  CHECK(voc.words() > 400);
  std::uint64_t s = 7;
  int same_word = 0, total = 0;
  double self_score = 0.0, other_score = 0.0;
  for (int place = 0; place < 60; ++place) {
    std::vector<Descriptor> revisit;
    for (const Descriptor& d : truth[place]) revisit.push_back(flip_bits(d, 10, &s));
    for (std::size_t i = 0; i < revisit.size(); ++i) {
      same_word += voc.word_of(revisit[i]) == voc.word_of(images[place][i]) ? 1 : 0;
      ++total;
    }
    BowVector a, b, c;
    voc.transform(revisit.data(), revisit.size(), &a);
    voc.transform(images[place].data(), images[place].size(), &b);
    voc.transform(images[(place + 1) % 60].data(), 40, &c);
    self_score += static_cast<double>(bow_score(a, b));
    other_score += static_cast<double>(bow_score(a, c));
  }
  INFO("same word " << same_word << " of " << total << "; mean score revisit " << self_score / 60 << ", other "
                    << other_score / 60);
  CHECK(same_word > 0.5 * total);  // 20 of 256 bits differ between two views: 61 % measured
  CHECK(self_score / 60 > 0.5);
  CHECK(other_score / 60 < 0.1);
}

TEST_CASE("Vocabulary: bytes round trip, corrupt, truncated, foreign and over-capacity files refused", "[loop]") {
  std::vector<std::vector<Descriptor>> truth;
  const auto images = places(10, 3, &truth);
  VocabularyParams p;
  p.k = 4;
  p.levels = 3;
  const Vocabulary voc = Vocabulary::train(images, p);
  const std::vector<std::uint8_t> bytes = voc.bytes();
  const Vocabulary back = Vocabulary::parse(bytes, "v.bin");
  CHECK(back.checksum() == voc.checksum());
  for (const auto& img : images)
    for (const Descriptor& d : img) CHECK(back.word_of(d) == voc.word_of(d));
  auto bad = bytes;
  bad[bad.size() / 2] ^= 0x10;
  CHECK_THROWS_WITH(Vocabulary::parse(bad, "v.bin"), Catch::Contains("v.bin") && Catch::Contains("CRC"));
  bad = bytes;
  bad.resize(bad.size() - 9);
  CHECK_THROWS_WITH(Vocabulary::parse(bad, "v.bin"), Catch::Contains("truncated"));
  bad = bytes;
  bad[0] = 'X';
  CHECK_THROWS_WITH(Vocabulary::parse(bad, "v.bin"), Catch::Contains("header"));
  bad = bytes;
  bad[12] = 200;  // k = 200
  CHECK_THROWS_WITH(Vocabulary::parse(bad, "v.bin"), Catch::Contains("k = 200"));
  VocabularyParams huge;
  huge.k = 10;
  huge.levels = 6;
  CHECK_THROWS_WITH(huge.validate(), Catch::Contains("kMaxVocabularyNodes"));
}
