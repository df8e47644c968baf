/*
 * pcl_mi for Python: numpy point arrays in, the engine's result out. The engine is
 * pcl_mi::RegistrationCore, the same one behind pcl::MutualInformationRegistration, so a
 * pose is bit-identical to the C++ API's for the same float32 points.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_mi/parameters.h>
#include <pcl_mi/registration_core.h>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <string>

namespace py = pybind11;

namespace {

/** (N, >= 3) float32 or float64 array as engine points (extra columns ignored). */
pcl_mi::PointList
toPoints(const py::array& array, const char* what)
{
  if (array.ndim() != 2 || array.shape(1) < 3)
    throw py::value_error(std::string(what) + " must be an (N, 3) or (N, >= 3) array, got shape " +
                          py::str(array.attr("shape")).cast<std::string>());
  if (array.shape(0) == 0)
    throw py::value_error(std::string(what) + " has no points");
  const py::dtype dtype = array.dtype();
  pcl_mi::PointList points(static_cast<std::size_t>(array.shape(0)));
  auto fill = [&](auto typed) {
    const auto view = typed.template unchecked<2>();
    for (py::ssize_t i = 0; i < view.shape(0); ++i)
      points[static_cast<std::size_t>(i)] =
          Eigen::Vector3f(static_cast<float>(view(i, 0)), static_cast<float>(view(i, 1)),
                          static_cast<float>(view(i, 2)));
  };
  if (dtype.kind() == 'f' && dtype.itemsize() == 4)
    fill(array.cast<py::array_t<float>>());
  else if (dtype.kind() == 'f' && dtype.itemsize() == 8)
    fill(array.cast<py::array_t<double>>());
  else
    throw py::value_error(std::string(what) + " must be float32 or float64, got " +
                          py::str(dtype.attr("name")).cast<std::string>());
  return points;
}

Eigen::Matrix4d
toPose(const py::object& object, const char* what)
{
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  if (object.is_none())
    return pose;
  const auto array = py::array_t<double, py::array::forcecast>::ensure(object);
  if (!array || array.ndim() != 2 || array.shape(0) != 4 || array.shape(1) != 4)
    throw py::value_error(std::string(what) + " must be a 4x4 array");
  const auto view = array.unchecked<2>();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      pose(r, c) = view(r, c);
  if (!pose.allFinite())
    throw py::value_error(std::string(what) + " must be finite");
  return pose;
}

py::array_t<double>
toArray(const Eigen::MatrixXd& m)
{
  py::array_t<double> out({m.rows(), m.cols()});
  auto view = out.mutable_unchecked<2>();
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      view(r, c) = m(r, c);
  return out;
}

/** The keyword parameters, named as the fields of pcl_mi::Parameters' groups; the
 * refinement's own fields carry its prefix, and max_iterations is the search's cap. */
struct Settings {
  pcl_mi::Parameters parameters;
  int max_iterations = pcl_mi::kDefaultMaxIterations;
};

Settings
toSettings(const py::kwargs& kwargs)
{
  Settings s;
  pcl_mi::Parameters& p = s.parameters;
  if (kwargs.contains("paper") && kwargs["paper"].cast<bool>())
    p = pcl_mi::Parameters::paper();
  using Setter = std::function<void(const py::handle&)>;
  auto text = [](const py::handle& v) { return v.cast<std::string>(); };
  const std::map<std::string, Setter> setters = {
      {"paper", [](const py::handle&) {}},
      {"resolution", [&](const py::handle& v) { p.grid.resolution = v.cast<double>(); }},
      {"feature",
       [&](const py::handle& v) {
         const std::string f = text(v);
         if (f != "varz" && f != "count")
           throw py::value_error("feature must be 'varz' or 'count', got '" + f + "'");
         p.grid.feature = f == "varz" ? pcl_mi::Feature::VarianceZ : pcl_mi::Feature::PointCount;
       }},
      {"pyramid_levels", [&](const py::handle& v) { p.grid.pyramid_levels = v.cast<int>(); }},
      {"source_subdivision",
       [&](const py::handle& v) { p.sampling.source_subdivision = v.cast<int>(); }},
      {"simplex_steps",
       [&](const py::handle& v) {
         const auto steps = v.cast<std::vector<double>>();
         if (steps.size() != 6)
           throw py::value_error("simplex_steps takes 6 values [tx, ty, tz, roll, pitch, yaw]");
         for (int i = 0; i < 6; ++i)
           p.search.simplex_steps[i] = steps[static_cast<std::size_t>(i)];
       }},
      {"symmetric_start", [&](const py::handle& v) { p.search.symmetric_start = v.cast<bool>(); }},
      {"heading_starts", [&](const py::handle& v) { p.search.heading_starts = v.cast<int>(); }},
      {"position_starts", [&](const py::handle& v) { p.search.position_starts = v.cast<int>(); }},
      {"narrow_view_position_starts",
       [&](const py::handle& v) { p.search.narrow_view_position_starts = v.cast<int>(); }},
      {"narrow_view_tilt_step",
       [&](const py::handle& v) { p.search.narrow_view_tilt_step = v.cast<double>(); }},
      {"narrow_view_yaw_start",
       [&](const py::handle& v) { p.search.narrow_view_yaw_start = v.cast<double>(); }},
      {"narrow_view_scanned_starts",
       [&](const py::handle& v) { p.search.narrow_view_scanned_starts = v.cast<int>(); }},
      {"reverse_search", [&](const py::handle& v) { p.search.reverse_search = v.cast<bool>(); }},
      {"second_search_headings",
       [&](const py::handle& v) { p.search.second_search_headings = v.cast<int>(); }},
      {"leveling", [&](const py::handle& v) { p.search.leveling = v.cast<bool>(); }},
      {"coarse_normalized_mi",
       [&](const py::handle& v) { p.search.coarse_normalized_mi = v.cast<bool>(); }},
      {"restarts", [&](const py::handle& v) { p.search.restarts = v.cast<int>(); }},
      {"restart_scale", [&](const py::handle& v) { p.search.restart_scale = v.cast<double>(); }},
      {"translation_tolerance",
       [&](const py::handle& v) { p.search.translation_tolerance = v.cast<double>(); }},
      {"rotation_tolerance",
       [&](const py::handle& v) { p.search.rotation_tolerance = v.cast<double>(); }},
      {"max_iterations", [&](const py::handle& v) { s.max_iterations = v.cast<int>(); }},
      {"refinement",
       [&](const py::handle& v) {
         p.refinement.method = v.cast<bool>() ? pcl_mi::Refinement::PointToDistribution
                                              : pcl_mi::Refinement::None;
       }},
      {"refinement_resolution",
       [&](const py::handle& v) { p.refinement.resolution = v.cast<double>(); }},
      {"refinement_max_iterations",
       [&](const py::handle& v) { p.refinement.max_iterations = v.cast<int>(); }},
      {"refinement_narrow_view_stages",
       [&](const py::handle& v) { p.refinement.narrow_view_stages = v.cast<int>(); }},
      {"backend",
       [&](const py::handle& v) {
         if (!pcl_mi::parseBackend(text(v), p.backend.type))
           throw py::value_error("backend must be 'cpu', 'opencl' or 'auto', got '" + text(v) +
                                 "'");
       }},
      {"batching",
       [&](const py::handle& v) {
         if (!pcl_mi::parseBatching(text(v), p.backend.batching))
           throw py::value_error("batching must be 'auto', 'on' or 'off', got '" + text(v) + "'");
       }},
      {"opencl_platform", [&](const py::handle& v) { p.backend.opencl_platform = v.cast<int>(); }},
      {"opencl_device", [&](const py::handle& v) { p.backend.opencl_device = v.cast<int>(); }},
      {"num_threads", [&](const py::handle& v) { p.num_threads = v.cast<int>(); }},
      {"units_per_metre", [&](const py::handle& v) { p.units_per_metre = v.cast<double>(); }},
  };
  for (const auto& [key, value] : kwargs) {
    const std::string name = key.cast<std::string>();
    const auto setter = setters.find(name);
    if (setter == setters.end())
      throw py::type_error("unknown parameter '" + name + "'");
    try {
      setter->second(value);
    }
    catch (const py::cast_error&) {
      throw py::value_error("parameter '" + name + "' has the wrong type");
    }
  }
  std::string invalid = p.validate();
  if (invalid.empty())
    invalid = pcl_mi::maxIterationsError(s.max_iterations);
  if (!invalid.empty())
    throw py::value_error("invalid parameters: " + invalid);
  return s;
}

/** What align() returns. */
struct Result {
  py::array_t<double> transformation;
  bool converged = false;
  double confidence = 0.0;
  std::string reason;
  std::string refusal;
  bool reverse_confirmed = false;
  py::array_t<double> covariance;
  double mutual_information = 0.0;
  int iterations = 0;
  int evaluations = 0;
  double seconds = 0.0;
  double resolution = 0.0;
  std::vector<std::string> warnings;
};

/** Scan-to-map: one target, many sources. */
class Registration {
public:
  explicit Registration(const py::kwargs& kwargs) : settings_(toSettings(kwargs))
  {
    core_.setParameters(settings_.parameters);
  }

  void
  setTarget(const py::array& points)
  {
    core_.setTarget(toPoints(points, "target"));
  }

  void
  setSource(const py::array& points)
  {
    core_.setSource(toPoints(points, "source"));
  }

  Result
  align(const py::array& source, const py::object& guess)
  {
    const Eigen::Matrix4d start = toPose(guess, "guess");
    pcl_mi::PointList points = toPoints(source, "source");
    pcl_mi::AlignmentResult result;
    const auto begin = std::chrono::steady_clock::now();
    {
      py::gil_scoped_release release; // other Python threads run meanwhile
      core_.setSource(std::move(points));
      result = core_.align(start, settings_.max_iterations);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    if (!result.error.empty())
      throw py::value_error(result.error);
    Result r;
    r.transformation = toArray(result.transformation);
    r.converged = result.converged;
    r.confidence = result.verification.confidence;
    r.reason = pcl_mi::notConvergedCause(
        result, settings_.max_iterations,
        "max_iterations=" + std::to_string(settings_.max_iterations));
    r.refusal = pcl_mi::refusalName(result.verification.refusal);
    r.reverse_confirmed = result.verification.reverse_confirmed;
    // Widened where the result depends on where the cells cut the surfaces: a refinement
    // more, after the alignment's time (RegistrationCore::covarianceScale()).
    Eigen::Matrix<double, 6, 6> covariance = result.verification.covariance;
    if (!covariance.isZero()) {
      py::gil_scoped_release release;
      covariance *= core_.covarianceScale();
    }
    r.covariance = toArray(covariance);
    r.mutual_information = result.mutual_information;
    r.iterations = result.iterations;
    r.evaluations = result.evaluations;
    r.seconds = seconds;
    r.resolution = core_.effectiveParameters().grid.resolution;
    r.warnings = result.warnings;
    return r;
  }

  double
  evaluate(const py::object& pose)
  {
    const Eigen::Matrix4d m = toPose(pose, "pose");
    std::string error;
    double mi = 0.0;
    {
      py::gil_scoped_release release;
      mi = core_.evaluate(m, &error);
    }
    if (!error.empty())
      throw py::value_error(error);
    return mi;
  }

private:
  Settings settings_;
  pcl_mi::RegistrationCore core_;
};

} // namespace

PYBIND11_MODULE(pcl_mi, m)
{
  m.doc() = "3D scan alignment by maximising the mutual information of voxel features "
            "(pcl_mi's engine; see docs/python.md).";
  py::class_<Result>(m, "Result", "Outcome of one alignment.")
      .def_readonly("transformation", &Result::transformation,
                    "4x4 float64 source-to-target transformation")
      .def_readonly("converged", &Result::converged,
                    "True only when the search converged and the result passed the "
                    "reliability test, or the alignment of the clouds swapped confirmed it "
                    "(docs/method.md, 'The verdict')")
      .def_readonly("reverse_confirmed", &Result::reverse_confirmed,
                    "True where the alignment of the clouds swapped confirmed a result the "
                    "reliability test held back")
      .def_readonly("confidence", &Result::confidence,
                    "probability that the result is within 0.5 m and 2 deg of the true pose")
      .def_readonly("reason", &Result::reason, "why converged is False ('' when True)")
      .def_readonly("refusal", &Result::refusal,
                    "which test of the verdict refused the result: 'none', 'too little shared "
                    "surface', 'degenerate', 'a second optimum' or 'weak evidence'")
      .def_readonly("covariance", &Result::covariance,
                    "6x6 covariance of the left increment [tx, ty, tz, roll, pitch, yaw] "
                    "(m, rad; target frame)")
      .def_readonly("mutual_information", &Result::mutual_information, "nats at the result")
      .def_readonly("iterations", &Result::iterations, "Nelder-Mead iterations")
      .def_readonly("evaluations", &Result::evaluations, "cost evaluations")
      .def_readonly("seconds", &Result::seconds, "wall-clock time of the alignment")
      .def_readonly("resolution", &Result::resolution,
                    "voxel size used: the one set, or the one derived from the target")
      .def_readonly("warnings", &Result::warnings, "what did not stop the alignment")
      .def("__repr__", [](const Result& r) {
        return "<pcl_mi.Result converged=" + std::string(r.converged ? "True" : "False") +
               " confidence=" + std::to_string(r.confidence) +
               " evaluations=" + std::to_string(r.evaluations) + ">";
      });
  py::class_<Registration>(m, "Registration",
                           "Registration(**parameters): one target, many sources (scan to map).")
      .def(py::init<const py::kwargs&>())
      .def("set_target", &Registration::setTarget, py::arg("points"),
           "Target points, (N, >= 3) float32 or float64")
      .def("set_source", &Registration::setSource, py::arg("points"),
           "Source points for evaluate()")
      .def("align", &Registration::align, py::arg("source"), py::arg("guess") = py::none(),
           "Aligns source onto the target from guess (4x4, default identity)")
      .def("evaluate", &Registration::evaluate, py::arg("pose"),
           "Mutual information (nats) of the last source at pose");
  m.def(
      "align",
      [](const py::array& source, const py::array& target, const py::object& guess,
         const py::kwargs& kwargs) {
        Registration registration(kwargs);
        registration.setTarget(target);
        return registration.align(source, guess);
      },
      py::arg("source"), py::arg("target"), py::arg("guess") = py::none(),
      "align(source, target, guess=None, **parameters) -> Result: aligns source onto target");
  m.attr("__version__") = PCL_MI_VERSION;
}
