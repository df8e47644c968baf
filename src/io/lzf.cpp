/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "io/lzf.h"

#include <cstring>

namespace pcl_mi {
namespace io {
namespace detail {

std::size_t
lzfDecompress(const std::uint8_t* in,
              std::size_t in_bytes,
              std::uint8_t* out,
              std::size_t out_bytes)
{
  std::size_t i = 0, o = 0; // read and write positions
  while (i < in_bytes) {
    const std::size_t control = in[i++];
    if (control < 32) {
      const std::size_t length = control + 1;
      if (length > in_bytes - i || length > out_bytes - o)
        return 0;
      std::memcpy(out + o, in + i, length);
      i += length;
      o += length;
      continue;
    }
    std::size_t length = control >> 5;
    if (length == 7) {
      if (i >= in_bytes)
        return 0;
      length += in[i++];
    }
    if (i >= in_bytes)
      return 0;
    const std::size_t back = ((control & 31) << 8) + in[i++] + 1;
    length += 2;
    if (back > o || length > out_bytes - o)
      return 0;
    // Byte by byte: a reference closer than its length repeats what it has just written.
    const std::uint8_t* from = out + (o - back);
    for (std::size_t k = 0; k < length; ++k)
      out[o + k] = from[k];
    o += length;
  }
  return o;
}

} // namespace detail
} // namespace io
} // namespace pcl_mi
