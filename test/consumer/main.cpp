// Aligns a scan pair with the installed package and checks the result against a
// reference transform: consumer SOURCE TARGET REFERENCE.
#include <pcl_mi/io.h>
#include <pcl_mi/mutual_information_registration.h>

#include <iostream>

int
main(int argc, char** argv)
{
  if (argc != 4) {
    std::cerr << "usage: consumer SOURCE TARGET REFERENCE\n";
    return 2;
  }
  auto source = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  auto target = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  pcl::PointCloud<pcl::PointXYZI> scan;
  for (auto [path, cloud] : {std::make_pair(argv[1], source), std::make_pair(argv[2], target)}) {
    const std::string error = pcl_mi::io::loadCloud(path, scan);
    if (!error.empty()) {
      std::cerr << error << "\n";
      return 2;
    }
    pcl::copyPointCloud(scan, *cloud);
  }
  Eigen::Matrix4d reference;
  if (!pcl_mi::io::loadTransform(argv[3], reference).empty())
    return 2;

  pcl::MutualInformationRegistration<pcl::PointXYZ> reg;
  reg.setInputSource(source);
  reg.setInputTarget(target);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  reg.align(aligned);
  const auto e = pcl_mi::io::poseError(reg.getFinalTransformation().cast<double>(), reference);
  std::cout << "consumer: converged " << reg.hasConverged() << ", error " << e.translation
            << " m, " << e.rotation_deg << " deg\n";
  return reg.hasConverged() && e.translation < 0.15 && e.rotation_deg < 0.5 ? 0 : 1;
}
