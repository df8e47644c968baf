/*
 * libFuzzer target: the cloud readers (PCD, PLY, KITTI .bin) on arbitrary bytes. The first
 * byte picks the format; the rest is the file. Any input must give a cloud or an error
 * message, never a crash, hang or unbounded allocation.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/io.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <unistd.h>

extern "C" int
LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  if (size < 1)
    return 0;
  static const char* const kExtensions[] = {".pcd", ".ply", ".bin"};
  const std::string path = "/tmp/pcl_mi_fuzz_reader_" + std::to_string(getpid()) +
                           kExtensions[data[0] % 3];
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  pcl::PointCloud<pcl::PointXYZI> cloud;
  const std::string error = pcl_mi::io::loadCloud(path, cloud);
  // A reader that reports success must hand over a usable cloud.
  if (error.empty() && cloud.size() != static_cast<std::size_t>(cloud.width) * cloud.height)
    __builtin_trap();
  std::remove(path.c_str());
  return 0;
}
