#include "posekit/shape/layered_representation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "posekit/body/parts.h"
#include "posekit/body/subjects.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/datasets/remesh.h"
#include "posekit/shape/body_features.h"
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

TEST(LayeredRepresentation, OnTwoThreadsAndFromTheFeaturesSurfaceTheSameToTheBit) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  // A 50k-vertex remesh (scan-like: its sections are sliced in several ranges per thread), with a
  // hole at the waist and a floating bit: features and representation on two threads, and the
  // representation cut from the surface the features gave, equal the single-thread ones made the
  // plain way.
  TriangleMesh mesh = remesh_body(build_body(model, make_subject_spec(model, 1, 3).spec).mesh, 50000);
  std::vector<bool> keep(static_cast<size_t>(mesh.F.rows()), true);
  const double waist = mesh.V.col(1).minCoeff() + 0.6 * (mesh.V.col(1).maxCoeff() - mesh.V.col(1).minCoeff());
  Eigen::Vector3d front(mesh.V.col(0).mean(), waist, -1);  // the front of the belly at that height
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
    if (std::abs(mesh.V(v, 1) - waist) < 0.01 && std::abs(mesh.V(v, 0) - front.x()) < 0.05) front.z() = std::max(front.z(), mesh.V(v, 2));
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    keep[static_cast<size_t>(f)] = (mesh.V.row(mesh.F(f, 0)).transpose() - front).norm() > 0.1;
  const Eigen::Index faces = mesh.F.rows();
  mesh = extract_faces(mesh, keep);
  ASSERT_LT(mesh.F.rows(), faces - 100);  // the hole is there
  // And a floating bit (a scan's strap): the ring around the hole copied 30 cm ahead of the body.
  {
    std::vector<bool> ring(static_cast<size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
      ring[static_cast<size_t>(f)] = (mesh.V.row(mesh.F(f, 0)).transpose() - front).norm() < 0.13;
    TriangleMesh bit = extract_faces(mesh, ring);
    ASSERT_GT(bit.F.rows(), 100);
    bit.V.col(2).array() += 0.3;
    const Eigen::Index nv = mesh.V.rows(), nf = mesh.F.rows();
    mesh.V.conservativeResize(nv + bit.V.rows(), 3);
    mesh.V.bottomRows(bit.V.rows()) = bit.V;
    mesh.F.conservativeResize(nf + bit.F.rows(), 3);
    mesh.F.bottomRows(bit.F.rows()) = bit.F.array() + static_cast<int>(nv);
  }
  std::vector<std::vector<int>> boundary1, boundary2;  // the input's, found beside the rest on two threads
  const TriangleMesh surface1 = body_surface(mesh.V, mesh.F, nullptr, nullptr, nullptr, &boundary1, 1);
  const TriangleMesh surface2 = body_surface(mesh.V, mesh.F, nullptr, nullptr, nullptr, &boundary2, 2);
  EXPECT_TRUE(surface1.V == surface2.V);
  EXPECT_TRUE(surface1.F == surface2.F);
  EXPECT_EQ(boundary1, boundary2);
  const BodyFeatures f1 = find_body_features(mesh.V, mesh.F);
  ASSERT_FALSE(f1.warnings.empty());
  EXPECT_NE(f1.warnings.front().find("left out 1 floating piece"), std::string::npos) << f1.warnings.front();
  TriangleMesh surface;
  const BodyFeatures f2 = find_body_features(mesh.V, mesh.F, &surface, 2);
  for (int side : {kLeft, kRight}) {
    EXPECT_TRUE(f1.wrist[side] == f2.wrist[side]);
    EXPECT_TRUE(f1.elbow[side] == f2.elbow[side]);
    EXPECT_TRUE(f1.shoulder[side] == f2.shoulder[side]);
    EXPECT_TRUE(f1.knee[side] == f2.knee[side]);
  }
  EXPECT_EQ(f1.crotch_y, f2.crotch_y);
  EXPECT_EQ(f1.arms_separate_y, f2.arms_separate_y);
  for (auto level : {&BodyFeatures::hip_y, &BodyFeatures::waist_y, &BodyFeatures::underbust_y, &BodyFeatures::bust_y,
                     &BodyFeatures::neck_y})  // from the torso's girths
    EXPECT_EQ(f1.*level, f2.*level);
  EXPECT_EQ(f1.warnings, f2.warnings);
  const LayeredRepresentation plain = build_layered_representation(mesh.V, mesh.F, f1);
  const LayeredRepresentation on_surface = build_layered_representation_on_surface(surface, f2, 32, 2);
  EXPECT_TRUE(plain.mesh.V == on_surface.mesh.V);
  EXPECT_TRUE(plain.mesh.F == on_surface.mesh.F);
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

TEST(LayeredRepresentation, SectionsCrossAScansHolesAndIgnoreItsFloatingBits) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  // Holes of 3 cm at the front of the head, the waist and a thigh, and a loose triangle inside the
  // waist (a scan's debris): the representation stays within a few millimetres of the whole body's.
  // (Registration.CtffdRegistersEveryBodyWithHolesOfTheRobustnessSet has the holes that once broke it.)
  const Body b = build_body(model, BodySpec{});
  const BodyFeatures whole_features = find_body_features(b.mesh.V, b.mesh.F);
  const LayeredRepresentation whole = build_layered_representation(b.mesh.V, b.mesh.F, whole_features);
  const auto front_point = [&](double y, double x) {
    Eigen::Index best = 0;
    for (Eigen::Index v = 0; v < b.mesh.V.rows(); ++v)
      if (std::abs(b.mesh.V(v, 1) - y) < 0.01 && std::abs(b.mesh.V(v, 0) - x) < 0.02 && b.mesh.V(v, 2) > b.mesh.V(best, 2)) best = v;
    return Eigen::Vector3d(b.mesh.V.row(best).transpose());
  };
  const Eigen::Vector3d centres[] = {front_point(0.5 * (whole_features.neck_top.y() + whole_features.crown_y), 0.0),
                                     front_point(whole_features.waist_y, 0.0),
                                     front_point(0.5 * (whole_features.crotch_y + whole_features.knee[0].y()), whole_features.knee[0].x())};
  std::vector<bool> keep(static_cast<size_t>(b.mesh.F.rows()), true);
  for (Eigen::Index f = 0; f < b.mesh.F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      for (const Eigen::Vector3d& centre : centres)
        if ((b.mesh.V.row(b.mesh.F(f, c)).transpose() - centre).norm() < 0.03) keep[static_cast<size_t>(f)] = false;
  TriangleMesh holed = extract_faces(b.mesh, keep);
  const Eigen::Index n = holed.V.rows();
  holed.V.conservativeResize(n + 3, 3);
  const double wy = whole_features.waist_y, wx = whole_features.axis_x, wz = whole_features.crotch.z();
  holed.V.bottomRows(3) << wx, wy - 0.01, wz, wx + 0.01, wy + 0.01, wz, wx - 0.01, wy + 0.01, wz + 0.005;
  holed.F.conservativeResize(holed.F.rows() + 1, 3);
  holed.F.bottomRows(1) << static_cast<int>(n), static_cast<int>(n + 1), static_cast<int>(n + 2);
  const LayeredRepresentation rep = build_layered_representation(holed.V, holed.F, find_body_features(holed.V, holed.F));
  ASSERT_EQ(rep.mesh.V.rows(), whole.mesh.V.rows());
  EXPECT_LT((rep.mesh.V - whole.mesh.V).rowwise().norm().mean(), 0.005);
}
