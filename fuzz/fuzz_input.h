/*
 * pcl_mi fuzzing: reads a libFuzzer input front to back, for the targets that build their
 * cases (clouds, headers, call sequences) from it.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace pcl_mi {
namespace fuzz {

/** The input's bytes in order; zeros once it runs out, so every case is complete. */
class FuzzInput {
public:
  FuzzInput(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::uint8_t
  byte()
  {
    return pos_ < size_ ? data_[pos_++] : 0;
  }
  std::int16_t
  int16()
  {
    const unsigned low = byte();
    return static_cast<std::int16_t>(low | (unsigned{byte()} << 8));
  }
  std::uint32_t
  uint32()
  {
    std::uint32_t v = 0;
    for (int shift = 0; shift < 32; shift += 8)
      v |= std::uint32_t{byte()} << shift;
    return v;
  }
  bool
  empty() const
  {
    return pos_ >= size_;
  }
  /** What is left, as a string; the input is used up after. */
  std::string
  rest()
  {
    const std::string s(reinterpret_cast<const char*>(data_ + pos_), size_ - pos_);
    pos_ = size_;
    return s;
  }

private:
  const std::uint8_t* data_;
  std::size_t size_, pos_ = 0;
};

} // namespace fuzz
} // namespace pcl_mi
