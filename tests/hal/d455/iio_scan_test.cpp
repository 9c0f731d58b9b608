#include "hal/d455/iio_scan.hpp"

#include <catch2/catch.hpp>

#include <cstring>

using namespace ums::d455;

TEST_CASE("IIO type descriptions parse endianness, sign, bits, storage, shift and repeat", "[d455][iio]") {
  IioChannelType t;
  REQUIRE(parse_iio_type("le:s16/32>>0", &t));
  CHECK_FALSE(t.big_endian);
  CHECK(t.is_signed);
  CHECK(t.bits == 16);
  CHECK(t.storage_bits == 32);
  CHECK(t.shift == 0);
  REQUIRE(parse_iio_type("be:u12/16>>4", &t));
  CHECK(t.big_endian);
  CHECK_FALSE(t.is_signed);
  CHECK(t.bits == 12);
  CHECK(t.shift == 4);
  REQUIRE(parse_iio_type("le:s64/64>>0", &t));
  CHECK(t.bits == 64);
  REQUIRE(parse_iio_type("le:s16/16X3>>0", &t));
  CHECK(t.repeat == 3);
  CHECK_FALSE(parse_iio_type("le:s33/32>>0", &t));
  CHECK_FALSE(parse_iio_type("me:s16/32>>0", &t));
  CHECK_FALSE(parse_iio_type("le:s16/32", &t));
  CHECK_FALSE(parse_iio_type("le:s16/32>>0 trailing", &t));
  CHECK_FALSE(parse_iio_type("", &t));
}

TEST_CASE("IIO scan layout of the D455: x@0 y@4 z@8, s64 timestamp aligned to 16, 24-byte records", "[d455][iio]") {
  IioScanLayout layout;
  IioChannelType s32, s64;
  REQUIRE(parse_iio_type("le:s32/32>>0", &s32));
  REQUIRE(parse_iio_type("le:s64/64>>0", &s64));
  const int ts = layout.add(3, s64);  // added out of index order on purpose
  const int z = layout.add(2, s32);
  const int x = layout.add(0, s32);
  const int y = layout.add(1, s32);
  REQUIRE(layout.finalize());
  CHECK(layout.at(x).offset == 0);
  CHECK(layout.at(y).offset == 4);
  CHECK(layout.at(z).offset == 8);
  CHECK(layout.at(ts).offset == 16);
  CHECK(layout.record_bytes() == 24);
}

TEST_CASE("IIO extraction sign-extends realbits, honours shift and big endian", "[d455][iio]") {
  IioChannel c;
  REQUIRE(parse_iio_type("le:s16/32>>0", &c.type));
  std::uint8_t rec[8] = {};
  // Only the low 16 bits are valid (LRS converter_16_bit): 0xABCDFF38 -> int16 0xFF38 = -200.
  const std::uint32_t v = 0xABCDFF38u;
  std::memcpy(rec, &v, 4);
  CHECK(iio_extract(rec, c) == -200);
  REQUIRE(parse_iio_type("be:u12/16>>4", &c.type));
  rec[0] = 0xAB;
  rec[1] = 0xC7;  // big endian 0xABC7 >> 4 = 0xABC
  CHECK(iio_extract(rec, c) == 0xABC);
  REQUIRE(parse_iio_type("be:s12/16>>4", &c.type));
  CHECK(iio_extract(rec, c) == 0xABC - 4096);
  REQUIRE(parse_iio_type("le:s64/64>>0", &c.type));
  const std::int64_t t = -5;
  std::memcpy(rec, &t, 8);
  CHECK(iio_extract(rec, c) == -5);
}
