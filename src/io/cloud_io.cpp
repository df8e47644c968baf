/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/io.h>

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>

#include <set>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <pcl/io/ply_io.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

namespace pcl_mi {
namespace io {

namespace {

std::string
lowerExtension(const std::string& path)
{
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos)
    return {};
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return ext;
}

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

/** \a v as float, beyond float's range as +-infinity (a plain conversion is undefined). */
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
            pcl::PointCloud<pcl::PointXYZI>& cloud)
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
    if (fieldSize(f->datatype) == 0 || f->offset + fieldSize(f->datatype) > blob.point_step)
      return "'" + path + "' has a field '" + kNames[k] + "' of an unusable type or layout";
  }
  const std::size_t n = static_cast<std::size_t>(blob.width) * blob.height;
  if (blob.row_step < static_cast<std::size_t>(blob.width) * blob.point_step ||
      blob.data.size() < static_cast<std::size_t>(blob.row_step) * blob.height)
    return "'" + path + "' is truncated: its header announces more points than it holds";
  cloud.clear();
  cloud.resize(n);
  cloud.width = blob.width;
  cloud.height = blob.height;
  cloud.is_dense = false;
  for (std::size_t row = 0, i = 0; row < blob.height; ++row)
    for (std::size_t col = 0; col < blob.width; ++col, ++i) {
      const std::uint8_t* point = blob.data.data() + row * blob.row_step + col * blob.point_step;
      pcl::PointXYZI& p = cloud[i];
      p.x = toFloat(fieldValue(point + fields[0]->offset, fields[0]->datatype));
      p.y = toFloat(fieldValue(point + fields[1]->offset, fields[1]->datatype));
      p.z = toFloat(fieldValue(point + fields[2]->offset, fields[2]->datatype));
      p.intensity =
          fields[3] ? toFloat(fieldValue(point + fields[3]->offset, fields[3]->datatype)) : 0.0f;
    }
  return {};
}

/** Checks that a file starts like a PCD file: optional comments, then the header keys up
 * to DATA. PCL 1.13's PCD reader crashes on some files that are not PCD at all, so they are
 * refused before it sees them. */
/** What a PCD header announces, validated. */
struct PcdHeader {
  std::vector<std::string> fields;
  std::vector<int> sizes, counts;
  std::vector<char> types;
  std::size_t points = 0;
  std::string data;          ///< ascii, binary or binary_compressed
  std::streamoff data_offset = 0;
};

/** Parses and checks a PCD header. Files that are not PCD, announce more than the file
 * holds or disagree with themselves are refused here: PCL 1.13's reader crashes, throws or
 * corrupts memory on such files (found by fuzz/fuzz_readers), so it never sees them. */
std::string
parsePcdHeader(const std::string& path, PcdHeader& h)
{
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  const double file_bytes = static_cast<double>(in.tellg());
  in.seekg(0);
  const std::string bad = "'" + path + "' has an invalid PCD header: ";
  // Plain non-negative integers only.
  auto integers = [](std::istringstream& words, std::vector<double>& out) {
    std::string word;
    while (words >> word) {
      if (word.empty() || word.size() > 15 ||
          word.find_first_not_of("0123456789") != std::string::npos)
        return false;
      out.push_back(std::stod(word));
    }
    return true;
  };
  std::set<std::string> seen;
  std::vector<double> sizes, counts, width, height, points;
  std::string line;
  for (int n = 0; n < 64 && std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
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
      h.data_offset = in.tellg();
      break;
    }
    else
      return "'" + path + "' is not a PCD file (unexpected header line '" + line.substr(0, 40) +
             "')";
    if (!ok)
      return bad + "malformed " + key + " line";
  }
  if (h.data.empty())
    return "'" + path + "' is not a PCD file (no DATA line)";
  if (h.data != "ascii" && h.data != "binary" && h.data != "binary_compressed")
    return bad + "unknown DATA '" + h.data.substr(0, 20) + "'";
  if (h.fields.empty() || width.empty() || height.empty())
    return bad + "FIELDS, WIDTH and HEIGHT are required";
  const std::size_t f = h.fields.size();
  if (counts.empty())
    counts.assign(f, 1.0);
  if (points.empty())
    points.push_back(width[0] * height[0]);
  if (sizes.size() != f || h.types.size() != f || counts.size() != f ||
      width[0] * height[0] != points[0])
    return bad + "FIELDS, SIZE, TYPE, COUNT, WIDTH x HEIGHT and POINTS disagree";
  double point_bytes = 0.0;
  for (std::size_t k = 0; k < f; ++k) {
    const bool valid_size = sizes[k] == 1 || sizes[k] == 2 || sizes[k] == 4 || sizes[k] == 8;
    if (!valid_size || (h.types[k] == 'F' && sizes[k] < 4) || counts[k] < 1 || counts[k] > 1e6)
      return bad + "invalid SIZE, TYPE or COUNT of field '" + h.fields[k].substr(0, 20) + "'";
    h.sizes.push_back(static_cast<int>(sizes[k]));
    h.counts.push_back(static_cast<int>(counts[k]));
    point_bytes += sizes[k] * counts[k];
  }
  // ASCII needs at least 2 characters a point, binary its exact bytes.
  const double data_bytes = file_bytes - static_cast<double>(h.data_offset);
  const double least =
      h.data == "binary" ? points[0] * point_bytes : h.data == "ascii" ? 2.0 * points[0] : 0.0;
  if (h.data_offset <= 0 || least > data_bytes)
    return "'" + path + "' is truncated: its header announces more points than it holds";
  h.points = static_cast<std::size_t>(points[0]);
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

/** Reads the data of an ascii or binary PCD into a blob (8-byte integers are not a PCL
 * datatype and are refused). */
std::string
readPcdData(const std::string& path, const PcdHeader& h, pcl::PCLPointCloud2& blob)
{
  blob = pcl::PCLPointCloud2();
  std::uint32_t offset = 0;
  for (std::size_t k = 0; k < h.fields.size(); ++k) {
    if (h.types[k] != 'F' && h.sizes[k] == 8)
      return "'" + path + "' has 8-byte integer field '" + h.fields[k] + "', not supported";
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
  blob.data.resize(static_cast<std::size_t>(blob.row_step));
  std::ifstream in(path, std::ios::binary);
  in.seekg(h.data_offset);
  if (h.data == "binary") {
    if (!in.read(reinterpret_cast<char*>(blob.data.data()),
                 static_cast<std::streamsize>(blob.data.size())))
      return "'" + path + "' is truncated";
    return {};
  }
  // ascii: one number per field element, whitespace-separated.
  std::string word;
  std::uint8_t* out = blob.data.data();
  for (std::size_t i = 0; i < h.points; ++i)
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
          return std::isfinite(v) || std::isinf(v) ? std::fmin(std::fmax(v, lo), hi) : 0.0;
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

std::string
checkPlyHeader(const std::string& path)
{
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  const double file_bytes = static_cast<double>(in.tellg());
  in.seekg(0);
  std::string line;
  std::getline(in, line);
  if (!line.empty() && line.back() == '\r')
    line.pop_back();
  if (line != "ply")
    return "'" + path + "' is not a PLY file";
  // PCL allocates the announced elements before reading them: every element takes at
  // least a byte, so a count beyond the file's size cannot be true.
  for (int n = 0; n < 256 && std::getline(in, line); ++n) {
    std::istringstream words(line);
    std::string key, name;
    double count = 0.0;
    words >> key;
    if (key == "end_header" || key == "end_header\r")
      return {};
    if (key == "element" && (!(words >> name >> count) || count < 0.0 || count > file_bytes)) {
      std::ostringstream s;
      s << "'" << path << "' is truncated or corrupt: element '" << name << "' announces "
        << count << " entries";
      return s.str();
    }
  }
  return "'" + path + "' is not a PLY file (no end_header)";
}

} // namespace

std::string
loadKittiBin(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in)
    return "cannot open '" + path + "'";
  const std::streamoff size = in.tellg();
  constexpr std::streamoff kPointBytes = 4 * sizeof(float);
  if (size <= 0 || size % kPointBytes != 0) {
    std::ostringstream s;
    s << "'" << path << "' is not a KITTI .bin scan: " << size
      << " bytes is not a positive multiple of 16 (float32 x, y, z, reflectance)";
    return s.str();
  }
  std::vector<float> data(static_cast<std::size_t>(size / sizeof(float)));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(data.data()), size))
    return "cannot read '" + path + "'";
  const std::size_t n = data.size() / 4;
  cloud.clear();
  cloud.resize(n);
  bool dense = true;
  for (std::size_t i = 0; i < n; ++i) {
    auto& p = cloud[i];
    p.x = data[4 * i];
    p.y = data[4 * i + 1];
    p.z = data[4 * i + 2];
    p.intensity = data[4 * i + 3];
    dense = dense && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
  }
  cloud.width = static_cast<std::uint32_t>(n);
  cloud.height = 1;
  cloud.is_dense = dense;
  return {};
}

std::string
loadCloud(const std::string& path, pcl::PointCloud<pcl::PointXYZI>& cloud)
{
  const std::string ext = lowerExtension(path);
  if (ext == "bin")
    return loadKittiBin(path, cloud);
  if (ext != "pcd" && ext != "ply")
    return "'" + path + "': unknown format (expected .pcd, .ply or KITTI .bin)";
  if (!std::ifstream(path))
    return "cannot open '" + path + "'";
  PcdHeader pcd;
  const std::string header_error = ext == "pcd" ? parsePcdHeader(path, pcd) : checkPlyHeader(path);
  if (!header_error.empty())
    return header_error;

  pcl::PCLPointCloud2 blob;
  int status = -1;
  // PCL's readers report their own details on the console; ours is the one-line summary.
  const auto verbosity = pcl::console::getVerbosityLevel();
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  try {
    // PCL 1.13's header parsers throw (std::out_of_range, boost::bad_lexical_cast, ...) on
    // some malformed headers; found by fuzz/fuzz_readers.
    if (ext == "pcd" && pcd.data != "binary_compressed") {
      const std::string error = readPcdData(path, pcd, blob);
      if (!error.empty()) {
        pcl::console::setVerbosityLevel(verbosity);
        return error;
      }
      status = 0;
    }
    else if (ext == "pcd")
      status = pcl::io::loadPCDFile(path, blob);
    else
      status = pcl::io::loadPLYFile(path, blob);
  }
  catch (const std::exception&) {
    status = -1;
  }
  pcl::console::setVerbosityLevel(verbosity);
  if (status < 0)
    return "cannot parse '" + path + "' as " + ext;
  if (!hasXyz(blob))
    return "'" + path + "' has no x, y, z fields";
  const std::string conversion_error = convertBlob(blob, path, cloud);
  if (!conversion_error.empty())
    return conversion_error;
  if (cloud.empty())
    return "'" + path + "' has no points";
  return {};
}

std::string
loadTransform(const std::string& path, Eigen::Matrix4d& transform)
{
  std::ifstream in(path);
  if (!in)
    return "cannot open '" + path + "'";
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::replace(text.begin(), text.end(), ',', ' ');
  std::istringstream s(text);
  std::vector<double> v;
  double x;
  while (s >> x)
    v.push_back(x);
  if (!s.eof())
    return "'" + path + "' holds something other than numbers";
  if (v.size() != 12 && v.size() != 16)
    return "'" + path + "' must hold 12 or 16 numbers, found " + std::to_string(v.size());
  transform.setIdentity();
  for (std::size_t i = 0; i < v.size(); ++i)
    transform(static_cast<int>(i / 4), static_cast<int>(i % 4)) = v[i];
  if (!transform.allFinite())
    return "'" + path + "' holds non-finite numbers";
  return {};
}

std::string
saveTransform(const std::string& path, const Eigen::Matrix4d& transform)
{
  std::ofstream out(path, std::ios::trunc);
  if (!out)
    return "cannot write '" + path + "'";
  char line[128];
  for (int r = 0; r < 4; ++r) {
    // 17 significant digits: the text reads back as the same doubles.
    std::snprintf(line, sizeof line, "%.17g %.17g %.17g %.17g\n", transform(r, 0),
                  transform(r, 1), transform(r, 2), transform(r, 3));
    out << line;
  }
  out.flush();
  if (!out)
    return "cannot write '" + path + "'";
  return {};
}

PoseError
poseError(const Eigen::Matrix4d& estimate, const Eigen::Matrix4d& reference)
{
  const Eigen::Matrix4d delta = reference.inverse() * estimate;
  PoseError e;
  e.translation = delta.topRightCorner<3, 1>().norm();
  const double c = std::min(1.0, std::max(-1.0, (delta.topLeftCorner<3, 3>().trace() - 1.0) / 2.0));
  e.rotation_deg = std::acos(c) * 180.0 / M_PI;
  return e;
}

std::string
saveMergedPcd(const std::string& path,
              const pcl::PointCloud<pcl::PointXYZI>& target,
              const pcl::PointCloud<pcl::PointXYZI>& aligned)
{
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    return "cannot open '" + path + "' for writing";
  const std::size_t total = target.size() + aligned.size();
  // The header PCL writes for PointXYZRGB, so PCL and pcl_viewer read it as their own.
  out << "# .PCD v0.7 - Point Cloud Data file format\n"
      << "VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
      << "WIDTH " << total << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << total
      << "\nDATA binary\n";
  constexpr std::size_t kChunkPoints = 1 << 16;
  struct Record {
    float x, y, z;
    std::uint32_t rgba;
  };
  static_assert(sizeof(Record) == 16, "PCD records are 16 packed bytes");
  std::vector<Record> chunk;
  chunk.reserve(kChunkPoints);
  auto write = [&](const pcl::PointCloud<pcl::PointXYZI>& cloud, std::uint32_t rgba) {
    for (std::size_t begin = 0; begin < cloud.size() && out; begin += kChunkPoints) {
      const std::size_t end = std::min(cloud.size(), begin + kChunkPoints);
      chunk.clear();
      for (std::size_t i = begin; i < end; ++i)
        chunk.push_back({cloud[i].x, cloud[i].y, cloud[i].z, rgba});
      out.write(reinterpret_cast<const char*>(chunk.data()),
                static_cast<std::streamsize>(chunk.size() * sizeof(Record)));
    }
  };
  write(target, 0xFFAAAAAAu);  // grey (170, 170, 170), opaque
  write(aligned, 0xFFE62828u); // red (230, 40, 40), opaque
  out.close();
  if (!out)
    return "cannot write '" + path + "' (disk full?)";
  return {};
}

} // namespace io
} // namespace pcl_mi
