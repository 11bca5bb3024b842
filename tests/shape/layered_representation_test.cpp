#include "posekit/shape/layered_representation.h"

#include <gtest/gtest.h>

#include <set>

#include "posekit/body/parts.h"
#include "posekit/datasets/remesh.h"
#include "posekit/datasets/subjects.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

TEST(LayeredRepresentation, EverySubjectGetsTheSameTopologyWithAllSixteenParts) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body templ = build_body(model, BodySpec{});
  const LayeredRepresentation reference =
      build_layered_representation(templ.mesh.V, templ.mesh.F, find_body_features(templ.mesh.V, templ.mesh.F));
  EXPECT_EQ(static_cast<int>(reference.layers.size()), representation_layer_count());
  EXPECT_EQ(reference.mesh.V.rows(), representation_layer_count() * reference.points_per_layer);
  std::set<int> parts(reference.triangle_part.data(), reference.triangle_part.data() + reference.triangle_part.size());
  EXPECT_EQ(parts.size(), static_cast<size_t>(kNumParts));
  for (const auto& s : make_subject_specs(model, 1, 16)) {
    const TriangleMesh mesh = remesh_body(build_body(model, s.spec).mesh, 12400);
    const LayeredRepresentation rep = build_layered_representation(mesh.V, mesh.F, find_body_features(mesh.V, mesh.F));
    EXPECT_EQ(rep.mesh.F, reference.mesh.F) << s.id;
    EXPECT_EQ(rep.triangle_part, reference.triangle_part) << s.id;
    // The representation lies on the body: its points are within 1 cm of the subject's vertices
    // (resampled contours run along the surface; hulls bridge only between fingers).
    const SurfacePoints on = closest_surface_points(mesh, rep.mesh.V);
    int far = 0;
    for (Eigen::Index i = 0; i < on.distance.size(); ++i) far += on.distance[i] > 0.01;
    EXPECT_LT(far, rep.mesh.V.rows() / 20) << s.id;
  }
}

TEST(LayeredRepresentation, FeatureLevelsAreLayers) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  const BodyFeatures f = find_body_features(b.mesh.V, b.mesh.F);
  const LayeredRepresentation rep = build_layered_representation(b.mesh.V, b.mesh.F, f);
  for (double level : {f.hip_y, f.waist_y, f.underbust_y, f.bust_y}) {
    bool found = false;
    for (const auto& L : rep.layers) found |= L.chain == 0 && std::abs(L.centre.y() - level) < 1e-9;
    EXPECT_TRUE(found) << "no torso layer at " << level;
  }
}
