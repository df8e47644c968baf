/*
 * pcl_mi io: LZF decompression, for PCD's binary_compressed data (internal).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <cstddef>
#include <cstdint>

namespace pcl_mi {
namespace io {
namespace detail {

/** Most bytes LZF can expand one byte of input into: its longest back reference is 3 bytes
 * that stand for 264. A binary_compressed header claiming more is corrupt, and is refused
 * before its claim is allocated. */
constexpr std::uint64_t kLzfMaxExpansion = 88;

/** \brief Unpacks the LZF stream \a in (\a in_bytes) into \a out, which holds \a out_bytes.
 * Returns the bytes written, or 0 where the stream is malformed: a run that ends past the
 * input, output that would pass \a out_bytes, or a back reference before the output's start.
 * Nothing outside \a in and \a out is read or written, whatever the stream holds.
 *
 * The stream is a sequence of runs, each led by a control byte c: below 32, the next c + 1
 * bytes are copied; else a length l = c >> 5 (7: plus the next byte) and an offset
 * o = (c & 31) << 8 plus the next byte copy l + 2 bytes from o + 1 bytes back in the output
 * (where the copy may overlap what it writes). PCL's own decompressor links all of pcl_io,
 * and with it VTK, into every program that reads a PCD file. */
std::size_t
lzfDecompress(const std::uint8_t* in,
              std::size_t in_bytes,
              std::uint8_t* out,
              std::size_t out_bytes);

} // namespace detail
} // namespace io
} // namespace pcl_mi
