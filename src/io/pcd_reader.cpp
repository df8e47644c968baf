/*
 * pcl_mi io: the PCD reader. It replaces PCL's (which crashes, throws, allocates what a
 * header claims or corrupts memory on malformed files; found by fuzz/fuzz_readers and by
 * an adversarial corpus, docs/hardening.md): every size is validated in 64-bit arithmetic
 * against the file's size before anything is allocated.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "io/file_checks.h"
#include "io/lzf.h"
#include "io/readers.h"

#include <pcl/PCLPointCloud2.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <vector>

namespace pcl_mi {
namespace io {
namespace detail {

float
toFloat(double v)
{
  constexpr double kMax = std::numeric_limits<float>::max();
  if (v > kMax)
    return std::numeric_limits<float>::infinity();
  if (v < -kMax)
    return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

namespace {

/** Largest point data a file may announce: PCLPointCloud2 holds it with 32-bit sizes. */
constexpr std::uint64_t kMaxPointDataBytes = std::numeric_limits<std::uint32_t>::max();

bool
hasXyz(const pcl::PCLPointCloud2& blob)
{
  // Each name once at least: "y y z" is not "x y z" (found by fuzz/fuzz_readers).
  bool x = false, y = false, z = false;
  for (const auto& f : blob.fields) {
    x = x || f.name == "x";
    y = y || f.name == "y";
    z = z || f.name == "z";
  }
  return x && y && z;
}

/** Value of a numeric field of any PCL datatype, as double. */
double
fieldValue(const std::uint8_t* at, std::uint8_t datatype)
{
  auto read = [at](auto value) {
    std::memcpy(&value, at, sizeof(value));
    return static_cast<double>(value);
  };
  switch (datatype) {
  case pcl::PCLPointField::INT8:
    return read(std::int8_t{});
  case pcl::PCLPointField::UINT8:
    return read(std::uint8_t{});
  case pcl::PCLPointField::INT16:
    return read(std::int16_t{});
  case pcl::PCLPointField::UINT16:
    return read(std::uint16_t{});
  case pcl::PCLPointField::INT32:
    return read(std::int32_t{});
  case pcl::PCLPointField::UINT32:
    return read(std::uint32_t{});
  case pcl::PCLPointField::FLOAT32:
    return read(float{});
  case pcl::PCLPointField::FLOAT64:
    return read(double{});
  default:
    return std::numeric_limits<double>::quiet_NaN();
  }
}

std::size_t
fieldSize(std::uint8_t datatype)
{
  switch (datatype) {
  case pcl::PCLPointField::INT8:
  case pcl::PCLPointField::UINT8:
    return 1;
  case pcl::PCLPointField::INT16:
  case pcl::PCLPointField::UINT16:
    return 2;
  case pcl::PCLPointField::INT32:
  case pcl::PCLPointField::UINT32:
  case pcl::PCLPointField::FLOAT32:
    return 4;
  case pcl::PCLPointField::FLOAT64:
    return 8;
  default:
    return 0;
  }
}

/** x, y, z (and intensity when present) of every point, from fields of any numeric type.
 * pcl::fromPCLPointCloud2 only matches float32 fields and leaves the coordinates at 0
 * otherwise: a double-precision PCD (common for georeferenced data) or one with integer
 * coordinates would load as a cloud of zeros without a word. */
std::string
convertBlob(const pcl::PCLPointCloud2& blob,
            const std::string& path,
            ScanPoints& cloud)
{
  const pcl::PCLPointField* fields[4] = {nullptr, nullptr, nullptr, nullptr};
  static const char* const kNames[4] = {"x", "y", "z", "intensity"};
  for (const auto& f : blob.fields)
    for (int k = 0; k < 4; ++k)
      if (f.name == kNames[k])
        fields[k] = &f;
  if (!fields[0] || !fields[1] || !fields[2])
    return "'" + path + "' has no x, y, z fields";
  for (int k = 0; k < 4; ++k) {
    const pcl::PCLPointField* f = fields[k];
    if (!f)
      continue;
    if (fieldSize(f->datatype) == 0 ||
        std::uint64_t{f->offset} + fieldSize(f->datatype) > blob.point_step)
      return "'" + path + "' has a field '" + kNames[k] + "' of an unusable type or layout";
  }
  const std::uint64_t n = std::uint64_t{blob.width} * blob.height;
  if (blob.row_step < std::uint64_t{blob.width} * blob.point_step ||
      blob.data.size() < std::uint64_t{blob.row_step} * blob.height)
    return "'" + path + "' is truncated: its header announces more points than it holds";
  cloud.xyzi.assign(4 * static_cast<std::size_t>(n), 0.0f);
  cloud.width = blob.width;
  cloud.height = blob.height;
  cloud.is_dense = false;
  for (std::size_t row = 0, i = 0; row < blob.height; ++row)
    for (std::size_t col = 0; col < blob.width; ++col, ++i) {
      const std::uint8_t* point = blob.data.data() + row * blob.row_step + col * blob.point_step;
      float* p = &cloud.xyzi[4 * i];
      for (int k = 0; k < 4; ++k)
        p[k] = fields[k] ? toFloat(fieldValue(point + fields[k]->offset, fields[k]->datatype))
                         : 0.0f;
    }
  return {};
}

/** What a PCD header announces, validated. */
struct PcdHeader {
  std::vector<std::string> fields;
  std::vector<int> sizes, counts;
  std::vector<char> types;
  std::uint64_t points = 0;
  std::uint64_t point_bytes = 0; ///< bytes of one point, every field
  std::string data;              ///< ascii, binary or binary_compressed
  std::uint64_t data_offset = 0;
  std::uint64_t data_bytes = 0;  ///< bytes of the file after the header
};

/** Parses and checks a PCD header: files that are not PCD, that announce more than the
 * file holds or more than a PCLPointCloud2 can hold, or that disagree with themselves are
 * refused here. */
std::string
parsePcdHeader(const std::string& path, std::uint64_t file_bytes, std::ifstream& in, PcdHeader& h)
{
  const std::string bad = "'" + path + "' has an invalid PCD header: ";
  // Plain non-negative integers of at most 15 digits (exact as doubles).
  auto integers = [](std::istringstream& words, std::vector<std::uint64_t>& out) {
    std::string word;
    while (words >> word) {
      if (word.empty() || word.size() > 15 ||
          word.find_first_not_of("0123456789") != std::string::npos)
        return false;
      out.push_back(std::strtoull(word.c_str(), nullptr, 10));
    }
    return true;
  };
  std::set<std::string> seen;
  std::vector<std::uint64_t> sizes, counts, width, height, points;
  std::string line;
  bool too_long = false;
  // Comment lines are unbounded in number (PCL's reader takes any); every other key may
  // appear once, so the header ends after a handful of lines or is refused.
  while (readBoundedLine(in, line, too_long)) {
    if (line.empty() || line[0] == '#')
      continue;
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (!seen.insert(key).second)
      return bad + "repeated " + key + " line";
    bool ok = true;
    if (key == "VERSION" || key == "VIEWPOINT")
      continue;
    if (key == "FIELDS") {
      std::string name;
      while (words >> name)
        h.fields.push_back(name);
    }
    else if (key == "TYPE") {
      std::string type;
      while (words >> type) {
        ok = ok && (type == "F" || type == "I" || type == "U");
        h.types.push_back(type[0]);
      }
    }
    else if (key == "SIZE")
      ok = integers(words, sizes);
    else if (key == "COUNT")
      ok = integers(words, counts);
    else if (key == "WIDTH")
      ok = integers(words, width) && width.size() == 1;
    else if (key == "HEIGHT")
      ok = integers(words, height) && height.size() == 1;
    else if (key == "POINTS")
      ok = integers(words, points) && points.size() == 1;
    else if (key == "DATA") {
      words >> h.data;
      const std::streamoff at = in.tellg();
      h.data_offset = at < 0 ? file_bytes : static_cast<std::uint64_t>(at);
      break;
    }
    else
      return "'" + path + "' is not a PCD file (unexpected header line '" + line.substr(0, 40) +
             "')";
    if (!ok)
      return bad + "malformed " + key + " line";
  }
  if (too_long)
    return bad + "a header line is longer than " + std::to_string(kMaxHeaderLineBytes) +
           " bytes";
  if (h.data.empty())
    return "'" + path + "' is not a PCD file (no DATA line)";
  if (h.data != "ascii" && h.data != "binary" && h.data != "binary_compressed")
    return bad + "unknown DATA '" + h.data.substr(0, 20) + "'";
  if (h.fields.empty() || width.empty() || height.empty())
    return bad + "FIELDS, WIDTH and HEIGHT are required";
  const std::size_t f = h.fields.size();
  if (counts.empty())
    counts.assign(f, 1);
  std::uint64_t announced = 0;
  if (!checkedMultiply(width[0], height[0], announced))
    return bad + "WIDTH x HEIGHT overflows";
  if (points.empty())
    points.push_back(announced);
  if (sizes.size() != f || h.types.size() != f || counts.size() != f || announced != points[0])
    return bad + "FIELDS, SIZE, TYPE, COUNT, WIDTH x HEIGHT and POINTS disagree";
  std::uint64_t values_per_point = 0;
  for (std::size_t k = 0; k < f; ++k) {
    const bool valid_size = sizes[k] == 1 || sizes[k] == 2 || sizes[k] == 4 || sizes[k] == 8;
    if (!valid_size || (h.types[k] == 'F' && sizes[k] < 4) || counts[k] < 1 || counts[k] > 1000000)
      return bad + "invalid SIZE, TYPE or COUNT of field '" + h.fields[k].substr(0, 20) + "'";
    h.sizes.push_back(static_cast<int>(sizes[k]));
    h.counts.push_back(static_cast<int>(counts[k]));
    // At most 2^16 fields of 8 x 10^6 bytes each: no overflow, but checked like the rest.
    if (!checkedAdd(h.point_bytes, sizes[k] * counts[k], h.point_bytes) ||
        !checkedAdd(values_per_point, counts[k], values_per_point))
      return bad + "the point size overflows";
  }
  h.points = points[0];
  std::uint64_t total = 0, values = 0;
  if (h.point_bytes > kMaxPointDataBytes || !checkedMultiply(h.points, h.point_bytes, total) ||
      total > kMaxPointDataBytes || !checkedMultiply(h.points, values_per_point, values)) {
    std::ostringstream s;
    s << "'" << path << "' announces " << h.points << " points of " << h.point_bytes
      << " bytes, more than the " << kMaxPointDataBytes << " bytes of point data a cloud can hold";
    return s.str();
  }
  if (h.data_offset == 0 || h.data_offset > file_bytes)
    return "'" + path + "' is truncated: its header announces more points than it holds";
  h.data_bytes = file_bytes - h.data_offset;
  // What the data needs at least: binary its exact bytes, ASCII a character and a
  // separator per value (the last separator may be missing), compressed its two sizes.
  const std::uint64_t least = h.data == "binary"  ? total
                              : h.data == "ascii" ? (values == 0 ? 0 : 2 * values - 1)
                                                  : 8;
  if (least > h.data_bytes)
    return "'" + path + "' is truncated: its header announces more points than it holds";
  return {};
}

std::uint8_t
pcdDatatype(char type, int size)
{
  switch (type) {
  case 'F':
    return size == 8 ? pcl::PCLPointField::FLOAT64 : pcl::PCLPointField::FLOAT32;
  case 'I':
    return size == 1 ? pcl::PCLPointField::INT8
                     : size == 2 ? pcl::PCLPointField::INT16 : pcl::PCLPointField::INT32;
  default:
    return size == 1 ? pcl::PCLPointField::UINT8
                     : size == 2 ? pcl::PCLPointField::UINT16 : pcl::PCLPointField::UINT32;
  }
}

/** The blob's fields, laid out one after the other in header order; with
 * \a skip_padding, without PCL's "_" padding fields (absent from compressed data).
 * parsePcdHeader() bounded point_bytes, so the 32-bit offsets cannot wrap. */
std::string
makeFields(const std::string& path, const PcdHeader& h, bool skip_padding,
           pcl::PCLPointCloud2& blob)
{
  blob = pcl::PCLPointCloud2();
  std::uint32_t offset = 0;
  for (std::size_t k = 0; k < h.fields.size(); ++k) {
    if (h.types[k] != 'F' && h.sizes[k] == 8)
      return "'" + path + "' has 8-byte integer field '" + h.fields[k] + "', not supported";
    if (skip_padding && h.fields[k] == "_")
      continue;
    pcl::PCLPointField field;
    field.name = h.fields[k];
    field.offset = offset;
    field.datatype = pcdDatatype(h.types[k], h.sizes[k]);
    field.count = static_cast<std::uint32_t>(h.counts[k]);
    blob.fields.push_back(field);
    offset += static_cast<std::uint32_t>(h.sizes[k] * h.counts[k]);
  }
  blob.point_step = offset;
  blob.width = static_cast<std::uint32_t>(h.points);
  blob.height = 1;
  blob.row_step = blob.point_step * blob.width;
  return {};
}

std::string
readAsciiData(const std::string& path, const PcdHeader& h, std::ifstream& in,
              pcl::PCLPointCloud2& blob)
{
  blob.data.resize(blob.row_step);
  std::string word;
  std::uint8_t* out = blob.data.data();
  for (std::uint64_t i = 0; i < h.points; ++i)
    for (std::size_t k = 0; k < h.fields.size(); ++k)
      for (int c = 0; c < h.counts[k]; ++c) {
        if (!(in >> word))
          return "'" + path + "' is truncated: its header announces more points than it holds";
        char* end = nullptr;
        const double v = std::strtod(word.c_str(), &end);
        if (end != word.c_str() + word.size())
          return "'" + path + "' has a non-number '" + word.substr(0, 20) + "' in its data";
        const std::uint8_t type = pcdDatatype(h.types[k], h.sizes[k]);
        auto put = [&](auto value) {
          std::memcpy(out, &value, sizeof(value));
          out += sizeof(value);
        };
        // Integers saturate at their type's range (a float-to-integer conversion out of
        // range is undefined; found by fuzz/fuzz_readers); NaN becomes 0.
        auto saturated = [v](double lo, double hi) {
          return std::isnan(v) ? 0.0 : std::fmin(std::fmax(v, lo), hi);
        };
        switch (type) {
        case pcl::PCLPointField::FLOAT64: put(v); break;
        case pcl::PCLPointField::FLOAT32: put(toFloat(v)); break;
        case pcl::PCLPointField::INT8: put(static_cast<std::int8_t>(saturated(-128.0, 127.0))); break;
        case pcl::PCLPointField::INT16: put(static_cast<std::int16_t>(saturated(-32768.0, 32767.0))); break;
        case pcl::PCLPointField::INT32: put(static_cast<std::int32_t>(saturated(-2147483648.0, 2147483647.0))); break;
        case pcl::PCLPointField::UINT8: put(static_cast<std::uint8_t>(saturated(0.0, 255.0))); break;
        case pcl::PCLPointField::UINT16: put(static_cast<std::uint16_t>(saturated(0.0, 65535.0))); break;
        default: put(static_cast<std::uint32_t>(saturated(0.0, 4294967295.0))); break;
        }
      }
  return {};
}

/** binary_compressed: two little-endian uint32 (compressed and uncompressed size), then
 * LZF data holding each field's values for all points in turn (padding fields left out). */
std::string
readCompressedData(const std::string& path, const PcdHeader& h, std::ifstream& in,
                   pcl::PCLPointCloud2& blob)
{
  std::uint32_t sizes[2] = {0, 0};
  if (!in.read(reinterpret_cast<char*>(sizes), sizeof sizes))
    return "'" + path + "' is truncated";
  const std::uint64_t compressed = sizes[0], uncompressed = sizes[1];
  const std::uint64_t expected = std::uint64_t{blob.row_step};
  std::ostringstream s;
  s << "'" << path << "' is corrupt: its binary_compressed data ";
  if (compressed > h.data_bytes - 8)
    s << "claims " << compressed << " bytes, the file holds " << h.data_bytes - 8;
  else if (uncompressed != expected)
    s << "unpacks to " << uncompressed << " bytes, its header announces " << expected;
  else if (uncompressed > kLzfMaxExpansion * compressed)
    s << "claims " << uncompressed << " bytes from " << compressed
      << ", more than LZF can expand";
  else
    s.str("");
  if (!s.str().empty())
    return s.str();
  if (expected == 0)
    return {};
  std::vector<std::uint8_t> packed(static_cast<std::size_t>(compressed));
  if (!in.read(reinterpret_cast<char*>(packed.data()), static_cast<std::streamsize>(packed.size())))
    return "'" + path + "' is truncated";
  std::vector<std::uint8_t> columns(static_cast<std::size_t>(uncompressed));
  if (lzfDecompress(packed.data(), packed.size(), columns.data(), columns.size()) != uncompressed)
    return "'" + path + "' is corrupt: its LZF data does not unpack";
  packed = {};
  blob.data.resize(blob.row_step);
  std::size_t column = 0;
  for (const auto& field : blob.fields) {
    const std::size_t bytes = fieldSize(field.datatype) * field.count;
    for (std::size_t i = 0; i < blob.width; ++i)
      std::memcpy(blob.data.data() + i * blob.point_step + field.offset,
                  columns.data() + column + i * bytes, bytes);
    column += bytes * blob.width;
  }
  return {};
}

} // namespace

std::string
readPcd(const std::string& path, ScanPoints& cloud)
{
  std::uint64_t file_bytes = 0;
  std::ifstream in;
  std::string error = openRegularFile(path, in, &file_bytes);
  if (!error.empty())
    return error;
  PcdHeader h;
  error = parsePcdHeader(path, file_bytes, in, h);
  if (!error.empty())
    return error;
  pcl::PCLPointCloud2 blob;
  const bool compressed = h.data == "binary_compressed";
  error = makeFields(path, h, compressed, blob);
  if (!error.empty())
    return error;
  // The header reader may have read ahead of the data: start it where DATA's line ends.
  in.clear();
  in.seekg(static_cast<std::streamoff>(h.data_offset));
  if (h.data == "binary") {
    blob.data.resize(blob.row_step);
    if (!in.read(reinterpret_cast<char*>(blob.data.data()),
                 static_cast<std::streamsize>(blob.data.size())))
      return "'" + path + "' is truncated";
  }
  else {
    error = compressed ? readCompressedData(path, h, in, blob) : readAsciiData(path, h, in, blob);
    if (!error.empty())
      return error;
  }
  if (!hasXyz(blob))
    return "'" + path + "' has no x, y, z fields";
  return convertBlob(blob, path, cloud);
}

} // namespace detail
} // namespace io
} // namespace pcl_mi
