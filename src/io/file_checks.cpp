/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "io/file_checks.h"

#include <sys/stat.h>

namespace pcl_mi {
namespace io {
namespace detail {

std::string
checkRegularFile(const std::string& path, std::uint64_t* bytes)
{
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0)
    return "cannot open '" + path + "'";
  if (!S_ISREG(info.st_mode))
    return "'" + path + "' is not a regular file (a directory, FIFO or device cannot be read)";
  if (bytes)
    *bytes = static_cast<std::uint64_t>(info.st_size);
  return {};
}

bool
readBoundedLine(std::istream& in, std::string& line, bool& too_long, std::size_t max_bytes)
{
  line.clear();
  too_long = false;
  std::istream::sentry ok(in, true);
  if (!ok)
    return false;
  std::streambuf* buffer = in.rdbuf();
  bool any = false;
  for (;;) {
    const int c = buffer->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      in.setstate(std::ios::eofbit);
      break;
    }
    any = true;
    if (c == '\n')
      break;
    if (line.size() == max_bytes) {
      too_long = true;
      return false;
    }
    line.push_back(static_cast<char>(c));
  }
  if (!line.empty() && line.back() == '\r')
    line.pop_back();
  if (!any)
    in.setstate(std::ios::failbit);
  return any;
}

std::string
openRegularFile(const std::string& path, std::ifstream& in, std::uint64_t* bytes)
{
  const std::string not_regular = checkRegularFile(path, bytes);
  if (!not_regular.empty())
    return not_regular;
  in.open(path, std::ios::binary);
  if (!in)
    return "cannot open '" + path + "'";
  return {};
}

} // namespace detail
} // namespace io
} // namespace pcl_mi
