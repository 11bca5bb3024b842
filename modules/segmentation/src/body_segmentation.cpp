#include "posekit/segmentation/body_segmentation.h"

#include "posekit/body/parts.h"
#include "posekit/segmentation/skeleton_embedding.h"

namespace posekit {
namespace {
constexpr double kSaidDisagreement = 0.03;  ///< m between the prior's joint and the body's own
}  // namespace

BodySegmentation segment_standing_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const LayeredRepresentation& rep,
                                       const BodyFeatures& features, const SegmentationPrior* prior) {
  BodySegmentation out;
  Eigen::VectorXi labels = prior ? representation_labels_from_prior(*prior, rep) : rep.triangle_part;
  SkeletonCheckOptions options;
  for (int side : {kLeft, kRight}) {
    if (!features.hand_cut[side]) continue;
    const int hand = side == kLeft ? kLeftHand : kRightHand, forearm = side == kLeft ? kLeftForearm : kRightForearm;
    for (Eigen::Index t = 0; t < labels.size(); ++t)
      if (labels[t] == hand) labels[t] = forearm;
    options.cut_off_parts.push_back(hand);
    out.notes.push_back(std::string("the ") + (side == kLeft ? "left" : "right") +
                        " hand is cut off: no triangle is labelled " + part_name(hand) + "; the wrist is the cut's centre");
  }
  out.segmentation = segment_body(V, F, rep, labels);
  if (prior) {
    // The limb joints are always the body's own (features follow a straight or cut arm, which the
    // prior's ct-FFD embedding does not); a prior more than 3 cm away is said.
    const Eigen::MatrixXd embedded = embed_skeleton(*prior, rep);
    reconcile_limb_joints(embedded, features, kSaidDisagreement, &out.notes);
    out.joints = reconcile_limb_joints(embedded, features, 0.0);
  } else {
    out.joints = joint_centres_from_features(V, F, out.segmentation.triangle_part, rep, features);
  }
  out.check = check_skeleton(V, F, out.segmentation.triangle_part, out.joints, options);
  return out;
}

}  // namespace posekit
