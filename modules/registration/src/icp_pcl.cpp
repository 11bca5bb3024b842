// PCL's point-to-point ICP, the rigid baseline of the paper's Table 1 (the "icp" plugin, see
// posekit/core/plugin.h): posekit loads PCL only where ICP runs.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>

#include <Eigen/Core>

#include "posekit/core/plugin.h"

/// The rigid transform (4x4, applied to source rows) after exactly `iterations` ICP iterations.
POSEKIT_PLUGIN_EXPORT void posekit_pcl_icp(const Eigen::MatrixXd& source, const Eigen::MatrixXd& target, int iterations,
                                           Eigen::Matrix4d* transform) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr src(new pcl::PointCloud<pcl::PointXYZ>), tgt(new pcl::PointCloud<pcl::PointXYZ>);
  for (Eigen::Index i = 0; i < source.rows(); ++i) src->push_back(pcl::PointXYZ(source(i, 0), source(i, 1), source(i, 2)));
  for (Eigen::Index i = 0; i < target.rows(); ++i) tgt->push_back(pcl::PointXYZ(target(i, 0), target(i, 1), target(i, 2)));
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputSource(src);
  icp.setInputTarget(tgt);
  icp.setMaximumIterations(iterations);
  icp.setTransformationEpsilon(0);  // run exactly the asked iterations, as the paper's Table 1
  icp.setEuclideanFitnessEpsilon(0);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  icp.align(aligned);
  *transform = icp.getFinalTransformation().cast<double>();
}
