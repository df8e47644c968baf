/*
 * pcl_mi io: the PLY reader. It replaces PCL's PLYReader, which aborts on assertions for
 * some valid-looking headers (a vertex list property of more than 255 entries) and
 * allocates what a header claims; docs/hardening.md.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "io/file_checks.h"
#include "io/readers.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

namespace pcl_mi {
namespace io {
namespace detail {

namespace {

enum class PlyFormat { Ascii, LittleEndian, BigEndian };

/** A scalar type: its size in bytes (0 = unknown name) and how to read it. */
struct PlyType {
  int bytes = 0;
  bool is_float = false;
  bool is_signed = false;
};

PlyType
plyType(const std::string& name)
{
  if (name == "char" || name == "int8")
    return {1, false, true};
  if (name == "uchar" || name == "uint8")
    return {1, false, false};
  if (name == "short" || name == "int16")
    return {2, false, true};
  if (name == "ushort" || name == "uint16")
    return {2, false, false};
  if (name == "int" || name == "int32")
    return {4, false, true};
  if (name == "uint" || name == "uint32")
    return {4, false, false};
  if (name == "float" || name == "float32")
    return {4, true, true};
  if (name == "double" || name == "float64")
    return {8, true, true};
  return {};
}

struct PlyProperty {
  std::string name;
  PlyType type;       ///< the value's type, or a list's item type
  bool list = false;
  PlyType count_type; ///< a list's count type
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;

  /** Fewest bytes one entry takes in the file. */
  std::uint64_t
  leastBytes(PlyFormat format) const
  {
    std::uint64_t bytes = 0;
    for (const auto& p : properties)
      bytes += format == PlyFormat::Ascii ? 2 : (p.list ? p.count_type.bytes : p.type.bytes);
    return std::max<std::uint64_t>(bytes, 1);
  }
};

struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElement> elements;
  std::uint64_t data_offset = 0;
};

std::string
parsePlyHeader(const std::string& path, std::uint64_t file_bytes, std::ifstream& in, PlyHeader& h)
{
  const std::string bad = "'" + path + "' has an invalid PLY header: ";
  std::string line;
  bool too_long = false;
  if (!readBoundedLine(in, line, too_long) || line != "ply")
    return "'" + path + "' is not a PLY file";
  bool has_format = false;
  while (readBoundedLine(in, line, too_long)) {
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key.empty() || key == "comment" || key == "obj_info")
      continue;
    if (key == "end_header") {
      if (!has_format)
        return bad + "no format line";
      const std::streamoff at = in.tellg();
      h.data_offset = at < 0 ? file_bytes : static_cast<std::uint64_t>(at);
      return {};
    }
    if (key == "format") {
      std::string format, version;
      words >> format >> version;
      if (format == "ascii")
        h.format = PlyFormat::Ascii;
      else if (format == "binary_little_endian")
        h.format = PlyFormat::LittleEndian;
      else if (format == "binary_big_endian")
        h.format = PlyFormat::BigEndian;
      else
        return bad + "unknown format '" + format.substr(0, 30) + "'";
      has_format = true;
    }
    else if (key == "element") {
      PlyElement e;
      std::string count;
      words >> e.name >> count;
      if (e.name.empty() || count.empty() || count.size() > 18 ||
          count.find_first_not_of("0123456789") != std::string::npos)
        return bad + "malformed element line '" + line.substr(0, 40) + "'";
      e.count = std::strtoull(count.c_str(), nullptr, 10);
      h.elements.push_back(e);
    }
    else if (key == "property") {
      if (h.elements.empty())
        return bad + "a property before any element";
      PlyProperty p;
      std::string type;
      words >> type;
      if (type == "list") {
        std::string count_type, item_type;
        words >> count_type >> item_type;
        p.list = true;
        p.count_type = plyType(count_type);
        p.type = plyType(item_type);
        if (p.count_type.bytes == 0 || p.count_type.is_float)
          return bad + "a list count of type '" + count_type.substr(0, 20) + "'";
      }
      else {
        p.type = plyType(type);
      }
      words >> p.name;
      if (p.type.bytes == 0 || p.name.empty())
        return bad + "malformed property line '" + line.substr(0, 40) + "'";
      h.elements.back().properties.push_back(p);
    }
    else {
      return bad + "unexpected line '" + line.substr(0, 40) + "'";
    }
  }
  if (too_long)
    return bad + "a header line is longer than " + std::to_string(kMaxHeaderLineBytes) +
           " bytes";
  return "'" + path + "' is not a PLY file (no end_header)";
}

/** Reads values of one element entry after another from the data section. */
class PlyValues {
public:
  PlyValues(std::ifstream& in, PlyFormat format, std::uint64_t bytes)
  : in_(in), format_(format), left_(bytes)
  {
  }

  /** The next value of type \a t; false when the data ends or is not a number. */
  bool
  next(const PlyType& t, double& value)
  {
    if (format_ == PlyFormat::Ascii) {
      if (!(in_ >> word_))
        return false;
      char* end = nullptr;
      value = std::strtod(word_.c_str(), &end);
      return end == word_.c_str() + word_.size();
    }
    if (left_ < static_cast<std::uint64_t>(t.bytes))
      return false;
    unsigned char raw[8];
    if (!in_.read(reinterpret_cast<char*>(raw), t.bytes))
      return false;
    left_ -= static_cast<std::uint64_t>(t.bytes);
    if (format_ == PlyFormat::BigEndian)
      std::reverse(raw, raw + t.bytes);
    value = decode(raw, t);
    return true;
  }

  /** Skips \a n values of type \a t; false when the data holds fewer. */
  bool
  skip(std::uint64_t n, const PlyType& t)
  {
    if (format_ == PlyFormat::Ascii) {
      double ignored = 0.0;
      for (std::uint64_t i = 0; i < n; ++i)
        if (!next(t, ignored))
          return false;
      return true;
    }
    std::uint64_t bytes = 0;
    if (!checkedMultiply(n, static_cast<std::uint64_t>(t.bytes), bytes) || bytes > left_)
      return false;
    in_.seekg(static_cast<std::streamoff>(bytes), std::ios::cur);
    left_ -= bytes;
    return static_cast<bool>(in_);
  }

  /** An upper bound on the values left: what a list count must not exceed. */
  std::uint64_t
  valuesLeft() const
  {
    return left_;
  }

private:
  static double
  decode(const unsigned char* raw, const PlyType& t)
  {
    auto as = [raw](auto v) {
      std::memcpy(&v, raw, sizeof v);
      return static_cast<double>(v);
    };
    if (t.is_float)
      return t.bytes == 8 ? as(double{}) : as(float{});
    switch (t.bytes) {
    case 1:
      return t.is_signed ? as(std::int8_t{}) : as(std::uint8_t{});
    case 2:
      return t.is_signed ? as(std::int16_t{}) : as(std::uint16_t{});
    default:
      return t.is_signed ? as(std::int32_t{}) : as(std::uint32_t{});
    }
  }

  std::ifstream& in_;
  PlyFormat format_;
  std::uint64_t left_; ///< binary: bytes left; ascii: the file's remaining size
  std::string word_;
};

} // namespace

std::string
readPly(const std::string& path, ScanPoints& cloud)
{
  std::uint64_t file_bytes = 0;
  std::ifstream in;
  std::string error = openRegularFile(path, in, &file_bytes);
  if (!error.empty())
    return error;
  PlyHeader h;
  error = parsePlyHeader(path, file_bytes, in, h);
  if (!error.empty())
    return error;
  const auto vertex = std::find_if(h.elements.begin(), h.elements.end(),
                                   [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex == h.elements.end())
    return "'" + path + "' has no vertex element";
  int axis[4] = {-1, -1, -1, -1}; // x, y, z, intensity
  static const char* const kNames[4] = {"x", "y", "z", "intensity"};
  for (std::size_t i = 0; i < vertex->properties.size(); ++i)
    for (int k = 0; k < 4; ++k)
      if (vertex->properties[i].name == kNames[k] && !vertex->properties[i].list)
        axis[k] = static_cast<int>(i);
  if (axis[0] < 0 || axis[1] < 0 || axis[2] < 0)
    return "'" + path + "' has no x, y, z fields";
  // Every entry of every element up to the vertices takes some bytes: a count the file
  // cannot hold is refused before anything is allocated for it.
  const std::uint64_t data_bytes = file_bytes - std::min(file_bytes, h.data_offset);
  std::uint64_t least = 0;
  for (auto e = h.elements.begin(); e <= vertex; ++e) {
    std::uint64_t bytes = 0;
    if (!checkedMultiply(e->count, e->leastBytes(h.format), bytes) ||
        !checkedAdd(least, bytes, least) || least > data_bytes) {
      std::ostringstream s;
      s << "'" << path << "' is truncated or corrupt: element '" << e->name.substr(0, 20)
        << "' announces " << e->count << " entries";
      return s.str();
    }
  }
  if (vertex->count > std::numeric_limits<std::uint32_t>::max())
    return "'" + path + "' has more vertices than a cloud can hold";

  PlyValues values(in, h.format, data_bytes);
  const std::string truncated = "'" + path + "' is truncated or holds a non-number";
  auto readList = [&](const PlyProperty& p) {
    double count = 0.0;
    if (!values.next(p.count_type, count) || !(count >= 0.0) ||
        count > static_cast<double>(values.valuesLeft()))
      return false;
    return values.skip(static_cast<std::uint64_t>(count), p.type);
  };
  for (auto e = h.elements.begin(); e != vertex; ++e)
    for (std::uint64_t i = 0; i < e->count; ++i)
      for (const auto& p : e->properties) {
        double ignored = 0.0;
        if (p.list ? !readList(p) : !values.next(p.type, ignored))
          return truncated;
      }
  cloud.xyzi.assign(4 * static_cast<std::size_t>(vertex->count), 0.0f);
  cloud.width = static_cast<std::uint32_t>(vertex->count);
  cloud.height = 1;
  cloud.is_dense = false;
  for (std::uint64_t i = 0; i < vertex->count; ++i) {
    float xyzi[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (std::size_t k = 0; k < vertex->properties.size(); ++k) {
      const PlyProperty& p = vertex->properties[k];
      double v = 0.0;
      if (p.list ? !readList(p) : !values.next(p.type, v))
        return truncated;
      for (int a = 0; a < 4; ++a)
        if (axis[a] == static_cast<int>(k))
          xyzi[a] = toFloat(v);
    }
    std::copy(xyzi, xyzi + 4, &cloud.xyzi[4 * static_cast<std::size_t>(i)]);
  }
  return {};
}

} // namespace detail
} // namespace io
} // namespace pcl_mi
