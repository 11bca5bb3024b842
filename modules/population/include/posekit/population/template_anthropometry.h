#pragma once
// ANSUR II measurements of any body in the MakeHuman template's topology, taken as a measurer would
// on the template: tape loops through fixed template edges (so they follow the body's shape),
// landmark vertices (crown, soles, crotch, acromia) and the rig's elbow and wrist joints.
#include <Eigen/Core>
#include <array>
#include <vector>

#include "posekit/body/makehuman_model.h"
#include "posekit/population/ansur.h"

namespace posekit {

/// A tape loop: points at fractions t along template edges (a, b), in rows of the positions that
/// measure_template_body takes; the tape is the convex hull of the points in their plane.
struct TapeLoop {
  std::vector<int> a, b;
  std::vector<double> t;
  bool horizontal = true;  ///< measured in the horizontal plane; else in the points' own best-fit plane
};

struct TemplateAnthropometry {
  /// Base-mesh vertices (skin and rig helpers) the measurements read; every index below is a row of
  /// the #vertices x 3 positions of these, in this order.
  std::vector<int> vertices;
  /// Loops of the girths, in SurveyMeasure order from kChestCircumference to kBicepsCircumference.
  std::array<TapeLoop, 7> loops;
  std::vector<int> crown, soles;                 ///< the highest and lowest vertices of the template (stature)
  int crotch = -1;                               ///< the crotch point's vertex
  std::array<int, 2> acromion{-1, -1};           ///< left, right: the shoulder points
  std::array<std::vector<int>, 2> elbow, wrist;  ///< rig joints: vertices whose mean is the joint
};

/// Defines the measurements on the body `spec` makes (a man's or a woman's template): girth levels
/// where posekit's measure_body finds them on it (chest = its bust level, buttock = its hip level,
/// thigh, calf, neck and upper arm), the waist at the navel (the vertices the MakeHuman navel
/// target moves), the acromion where the shoulder's top turns into the arm (the skin in the shoulder
/// joint's frontal plane whose normal points 45 degrees up and outward). Throws InvalidInput when the template cannot be measured.
TemplateAnthropometry make_template_anthropometry(const MakeHumanModel& model, const BodySpec& spec);

/// The measurements of a body: `P` holds the positions (m) of a.vertices (#vertices x 3). Girths are
/// convex-hull perimeters of the loops; stature = highest crown vertex minus lowest sole vertex;
/// crotch and acromial heights from the soles; biacromial breadth between the acromia; sleeve
/// outseam = acromion to elbow joint to wrist joint (mean of both arms).
SurveyValues measure_template_body(const TemplateAnthropometry& a, const Eigen::MatrixXd& P);

/// The positions measure_template_body takes, gathered from all base-mesh vertices (#base x 3).
Eigen::MatrixXd gather_measured_vertices(const TemplateAnthropometry& a, const Eigen::MatrixXd& base_V);

}  // namespace posekit
