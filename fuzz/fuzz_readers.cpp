/*
 * libFuzzer target: the cloud readers (PCD, PLY, KITTI .bin) on arbitrary bytes. The first
 * byte picks the mode: raw bytes as a .pcd, .ply or .bin file, or a structured PCD or PLY
 * whose header fields (sizes, counts, widths, list properties) are drawn from the input, so
 * that size arithmetic and list lengths are mutated directly rather than found by chance
 * (docs/hardening.md, classes 1, 2, 4 and 13). Any input must give a cloud or an error
 * message, never a crash, hang or unbounded allocation. fuzz/pcd_ply.dict holds the formats'
 * keywords for the raw modes.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "fuzz_input.h"

#include <pcl_mi/io.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

namespace {

using pcl_mi::fuzz::FuzzInput;

/** A size or count: mostly small, sometimes large, and the edges of 32 bits. */
std::uint64_t
count(FuzzInput& in)
{
  const std::uint8_t kind = in.byte();
  const std::uint32_t v = in.uint32();
  switch (kind % 8) {
  case 0:
    return 0;
  case 1:
    return v; // up to 2^32 - 1
  case 2:
    return std::uint64_t{1} << (v % 40);
  case 3:
    return (v & 0xffff) + 1;
  default:
    return kind % 16 + 1;
  }
}

std::string
structuredPcd(FuzzInput& in)
{
  static const char* const kData[] = {"ascii", "binary", "binary_compressed"};
  static const char* const kNames[] = {"x", "y", "z", "intensity", "_", "rgb", "normal_x"};
  static const char kTypes[] = {'F', 'I', 'U'};
  static const int kSizes[] = {1, 2, 4, 8};
  std::ostringstream s;
  for (int c = in.byte() % 4; c > 0; --c)
    s << "# comment " << c << "\n";
  const int fields = 1 + in.byte() % 7;
  std::ostringstream names, sizes, types, counts;
  for (int f = 0; f < fields; ++f) {
    names << " " << kNames[(f < 3 && in.byte() % 8) ? f : in.byte() % 7];
    sizes << " " << kSizes[in.byte() % 4];
    types << " " << kTypes[in.byte() % 3];
    counts << " " << count(in);
  }
  const std::uint64_t width = count(in), height = 1 + in.byte() % 3;
  s << "VERSION 0.7\nFIELDS" << names.str() << "\nSIZE" << sizes.str() << "\nTYPE" << types.str()
    << "\nCOUNT" << counts.str() << "\nWIDTH " << width << "\nHEIGHT " << height
    << "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << (in.byte() % 8 ? width * height : count(in))
    << "\nDATA " << kData[in.byte() % 3] << "\n";
  return s.str() + in.rest();
}

std::string
structuredPly(FuzzInput& in)
{
  static const char* const kFormats[] = {"ascii", "binary_little_endian", "binary_big_endian"};
  static const char* const kTypes[] = {"char", "uchar", "short", "ushort", "int",
                                       "uint", "float", "double", "int8", "float64"};
  std::ostringstream s;
  s << "ply\nformat " << kFormats[in.byte() % 3] << " 1.0\ncomment structured\n";
  auto properties = [&](bool vertex) {
    const int n = (vertex ? 3 : 0) + in.byte() % 4;
    for (int p = 0; p < n; ++p) {
      const char* name = vertex && p < 3 ? (p == 0 ? "x" : p == 1 ? "y" : "z") : "extra";
      if (in.byte() % 4 == 0)
        s << "property list " << kTypes[in.byte() % 6] << " " << kTypes[in.byte() % 10] << " "
          << name << "\n";
      else
        s << "property " << kTypes[in.byte() % 10] << " " << name << "\n";
    }
  };
  if (in.byte() % 2) {
    s << "element face " << count(in) << "\n";
    properties(false);
  }
  s << "element vertex " << count(in) << "\n";
  properties(true);
  s << "end_header\n";
  return s.str() + in.rest();
}

} // namespace

extern "C" int
LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  if (size < 1)
    return 0;
  static const char* const kExtensions[] = {".pcd", ".ply", ".bin", ".pcd", ".ply"};
  const int mode = data[0] % 5;
  const std::string path =
      "/tmp/pcl_mi_fuzz_reader_" + std::to_string(getpid()) + kExtensions[mode];
  FuzzInput in(data + 1, size - 1);
  const std::string bytes = mode == 3 ? structuredPcd(in) : mode == 4 ? structuredPly(in) : in.rest();
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  pcl::PointCloud<pcl::PointXYZI> cloud;
  const std::string error = pcl_mi::io::loadCloud(path, cloud);
  // A reader that reports success must hand over a usable cloud.
  if (error.empty() && cloud.size() != static_cast<std::size_t>(cloud.width) * cloud.height)
    __builtin_trap();
  std::remove(path.c_str());
  return 0;
}
