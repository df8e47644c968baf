/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "io/lzf.h"

#include <pcl/io/lzf.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

namespace {

using pcl_mi::io::detail::lzfDecompress;
using Bytes = std::vector<std::uint8_t>;

/** \a plain packed by PCL's compressor (the writer of binary_compressed PCD files). */
Bytes
packed(const Bytes& plain)
{
  Bytes out(plain.size() + plain.size() / 16 + 64);
  const unsigned int n = pcl::lzfCompress(plain.data(), static_cast<unsigned int>(plain.size()),
                                          out.data(), static_cast<unsigned int>(out.size()));
  out.resize(n);
  return out;
}

Bytes
unpacked(const Bytes& stream, std::size_t room, std::size_t* written = nullptr)
{
  Bytes out(room, 0xAB);
  const std::size_t n = lzfDecompress(stream.data(), stream.size(), out.data(), out.size());
  if (written)
    *written = n;
  return out;
}

TEST(Lzf, UnpacksWhatPclPacks)
{
  std::mt19937 random(7);
  // Noise (literal runs), repeats (long back references), and a PCD-like column of floats.
  Bytes noise(5000), repeats(70000), column(4 * 30000);
  for (auto& b : noise)
    b = static_cast<std::uint8_t>(random());
  for (std::size_t i = 0; i < repeats.size(); ++i)
    repeats[i] = static_cast<std::uint8_t>("pcl_mi"[i % 6] + (i / 5000));
  std::normal_distribution<float> height(0.0f, 2.0f);
  for (std::size_t i = 0; i < column.size() / 4; ++i) {
    const float v = i % 3 == 0 ? 0.0f : height(random);
    std::memcpy(column.data() + 4 * i, &v, 4);
  }
  for (const Bytes* plain : {&noise, &repeats, &column}) {
    const Bytes stream = packed(*plain);
    ASSERT_GT(stream.size(), 0u);
    std::size_t written = 0;
    EXPECT_EQ(unpacked(stream, plain->size(), &written), *plain);
    EXPECT_EQ(written, plain->size());
  }
  EXPECT_LT(packed(repeats).size(), repeats.size() / 20); // the references were exercised
}

TEST(Lzf, AnOverlappingReferenceRepeatsWhatItWrites)
{
  // "a", then a reference one byte back of length 2 + 5: "aaaaaaaa".
  const Bytes stream = {0x00, 'a', 0xA0, 0x00};
  std::size_t written = 0;
  const Bytes out = unpacked(stream, 8, &written);
  EXPECT_EQ(written, 8u);
  EXPECT_EQ(out, Bytes(8, 'a'));
}

TEST(Lzf, RefusesMalformedStreams)
{
  const Bytes good = packed(Bytes(3000, 'x'));
  std::size_t written = 1;
  // Output would pass the room given: nothing beyond it is written.
  Bytes out = unpacked(good, 2999, &written);
  EXPECT_EQ(written, 0u);
  // A literal run longer than the input left.
  unpacked({0x05, 'a', 'b'}, 16, &written);
  EXPECT_EQ(written, 0u);
  // A reference before the output's start.
  unpacked({0x00, 'a', 0x20, 0x05}, 16, &written);
  EXPECT_EQ(written, 0u);
  // A long reference cut after its control byte, and one cut before its offset byte.
  unpacked({0x00, 'a', 0xE0}, 300, &written);
  EXPECT_EQ(written, 0u);
  unpacked({0x00, 'a', 0xE0, 0x03}, 300, &written);
  EXPECT_EQ(written, 0u);
  unpacked({0x00, 'a', 0x20}, 16, &written);
  EXPECT_EQ(written, 0u);
  // Every truncation of a real stream either fails or unpacks a prefix of the data.
  for (std::size_t cut = 0; cut < good.size(); ++cut) {
    const Bytes part(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(cut));
    out = unpacked(part, 3000, &written);
    EXPECT_LE(written, 3000u);
    for (std::size_t i = 0; i < written; ++i)
      ASSERT_EQ(out[i], 'x');
  }
}

} // namespace
