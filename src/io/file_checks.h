/*
 * pcl_mi io: the checks every reader makes before it trusts a file (internal).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <istream>
#include <fstream>
#include <string>

namespace pcl_mi {
namespace io {
namespace detail {

/** Longest header line a reader accepts: PCD and PLY header lines are short, and a bound
 * keeps a file without line breaks from being read into one string. */
constexpr std::size_t kMaxHeaderLineBytes = 1 << 16;

/** Empty when \a path names a regular file that can be opened; otherwise the reason. A
 * FIFO, device or directory is refused before it is opened: reading one blocks or never
 * ends. On success \a bytes is the file's size. */
std::string
checkRegularFile(const std::string& path, std::uint64_t* bytes = nullptr);

/** checkRegularFile(), then opens \a path (binary) into \a in: empty, or the reason. */
std::string
openRegularFile(const std::string& path, std::ifstream& in, std::uint64_t* bytes = nullptr);

/** Reads one line into \a line without its line break (and a trailing '\r'). False at the
 * end of the input or when the line is longer than \a max_bytes (then \a too_long is set). */
bool
readBoundedLine(std::istream& in, std::string& line, bool& too_long,
                std::size_t max_bytes = kMaxHeaderLineBytes);

/** \a a * \a b, or false when the product does not fit in 64 bits. */
inline bool
checkedMultiply(std::uint64_t a, std::uint64_t b, std::uint64_t& product)
{
  return !__builtin_mul_overflow(a, b, &product);
}

/** \a a + \a b, or false when the sum does not fit in 64 bits. */
inline bool
checkedAdd(std::uint64_t a, std::uint64_t b, std::uint64_t& sum)
{
  return !__builtin_add_overflow(a, b, &sum);
}

} // namespace detail
} // namespace io
} // namespace pcl_mi
