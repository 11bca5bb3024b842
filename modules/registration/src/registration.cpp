#include "posekit/registration/registration.h"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>

#include <chrono>

#include "posekit/core/error.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/registration/correspondence.h"
#include "posekit/registration/ctffd.h"
#include "posekit/registration/nicp.h"
#include "posekit/shape/layered_representation.h"

namespace posekit {

RegistrationMethod parse_registration_method(const std::string& name) {
  if (name == "ctffd") return RegistrationMethod::kCtffd;
  if (name == "icp") return RegistrationMethod::kIcp;
  if (name == "nicp") return RegistrationMethod::kNicp;
  throw InvalidInput("unknown registration method '" + name + "': expected ctffd, icp or nicp");
}

RegistrationResult register_bodies(const TriangleMesh& source, const TriangleMesh& target, const RegistrationOptions& o) {
  require_usable_mesh(source, "registration source");
  require_usable_mesh(target, "registration target");
  const auto t0 = std::chrono::steady_clock::now();
  RegistrationResult r;
  if (o.method == RegistrationMethod::kCtffd) {
    const LayeredRepresentation rs =
        build_layered_representation(source.V, source.F, find_body_features(source.V, source.F), o.points_per_layer);
    const LayeredRepresentation rt =
        build_layered_representation(target.V, target.F, find_body_features(target.V, target.F), o.points_per_layer);
    r.deformed_source = ctffd_evaluate(ctffd_parametrize(source.V, rs), rt);
  } else if (o.method == RegistrationMethod::kNicp) {
    r.deformed_source = nonrigid_icp(source, target).V;
  } else {
    if (o.icp_iterations < 1) throw InvalidInput("ICP needs at least one iteration");
    pcl::PointCloud<pcl::PointXYZ>::Ptr src(new pcl::PointCloud<pcl::PointXYZ>), tgt(new pcl::PointCloud<pcl::PointXYZ>);
    for (Eigen::Index i = 0; i < source.V.rows(); ++i) src->push_back(pcl::PointXYZ(source.V(i, 0), source.V(i, 1), source.V(i, 2)));
    for (Eigen::Index i = 0; i < target.V.rows(); ++i) tgt->push_back(pcl::PointXYZ(target.V(i, 0), target.V(i, 1), target.V(i, 2)));
    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
    icp.setInputSource(src);
    icp.setInputTarget(tgt);
    icp.setMaximumIterations(o.icp_iterations);
    icp.setTransformationEpsilon(0);        // run exactly the asked iterations, as the paper's Table 1
    icp.setEuclideanFitnessEpsilon(0);
    pcl::PointCloud<pcl::PointXYZ> aligned;
    icp.align(aligned);
    const Eigen::Matrix4d T = icp.getFinalTransformation().cast<double>();
    r.deformed_source = (source.V * T.topLeftCorner<3, 3>().transpose()).rowwise() + T.topRightCorner<3, 1>().transpose();
  }
  r.correspondence = nearest_centroid_correspondence(r.deformed_source, source.F, target.V, target.F, &r.normal_failures);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace posekit
