#pragma once
// posekit's body model (issue 44): a shape space of the MakeHuman template topology that knows its
// joints (a population fitted to real proportions, posekit shape-space --ansur), the template's
// 16-part labels, and 16-part skinning weights from the rig's own weights. A body of any shape is
// posed by dual quaternion skinning about its own joints.
#include <Eigen/Core>
#include <memory>
#include <utility>
#include <vector>

#include "posekit/deformation/pose_fitting.h"
#include "posekit/registration/shape_space.h"

namespace posekit {

struct MakeHumanModel;

class BodyModel {
 public:
  /// Throws InvalidInput when the space is not of the template's topology or does not know its
  /// joints (a .pks written before version 2, or learned from meshes: rebuild it with shape-space).
  BodyModel(ShapeSpace space, const MakeHumanModel& makehuman);

  const ShapeSpace& space() const { return space_; }
  int components() const { return space_.components(); }
  const Eigen::MatrixXi& faces() const { return space_.faces; }
  const Eigen::VectorXi& vertex_parts() const { return vertex_part_; }  ///< #V: the part of largest weight
  /// Each vertex's parts and their weights (summing to 1): the rig's bone weights summed by part.
  const std::vector<std::vector<std::pair<int, double>>>& part_weights() const { return part_weights_; }

 private:
  ShapeSpace space_;
  Eigen::VectorXi vertex_part_;
  std::vector<std::vector<std::pair<int, double>>> part_weights_;
};

/// The model's body of shape coefficients c, posable by skinning (what fit_pose moves).
class ShapedBody final : public PosableBody {
 public:
  /// `threads` skin the whole body in pose() (1 where many bodies are posed at once).
  ShapedBody(const BodyModel& model, const Eigen::VectorXd& coefficients, int threads = 1);
  const Eigen::MatrixXd& rest_vertices() const override { return V_; }
  const Eigen::MatrixXi& faces() const override { return model_.faces(); }
  const Eigen::VectorXi& vertex_parts() const override { return model_.vertex_parts(); }
  const Eigen::MatrixXd& joint_centres() const override { return J_; }
  Eigen::MatrixXd joint_pivots() const override { return J_; }
  void pose(const PartPose& pose, Eigen::MatrixXd* X) const override;
  PartTransforms part_motions(const PartPose& pose) const override;
  /// The posed joint centres (#joints x 3): where each child part carries its joint.
  Eigen::MatrixXd posed_joints(const PartPose& pose) const;
  const Eigen::VectorXd& coefficients() const { return c_; }

  /// Dual quaternion skinning by the part motions T of the model's vertices `rows` (all when empty)
  /// placed at V (#V x 3, all vertices), into X (#rows x 3).
  static void skin(const BodyModel& model, const Eigen::MatrixXd& V, const PartTransforms& T, const std::vector<int>& rows,
                   Eigen::MatrixXd* X, int threads = 1);

 private:
  const BodyModel& model_;
  Eigen::VectorXd c_;
  Eigen::MatrixXd V_, J_;
  int threads_ = 1;
};

}  // namespace posekit
