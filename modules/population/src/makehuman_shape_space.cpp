#include "posekit/population/makehuman_shape_space.h"

namespace posekit {

ShapeSpace makehuman_shape_space(const MakeHumanModel& model, const PopulationOptions& population, double variance_kept,
                                 int max_components) {
  std::string note;
  const std::vector<Eigen::MatrixXd> bodies = make_population_bodies(model, population, &note);
  ShapeSpace space = learn_shape_space(bodies, variance_kept, max_components, note);
  space.faces = model.body_F;
  return space;
}

}  // namespace posekit
