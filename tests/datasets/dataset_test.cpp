#include "posekit/datasets/dataset.h"
#include "posekit/deformation/pose_dataset.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "posekit/body/subjects.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/datasets/remesh.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/image_io.h"
#include "posekit/io/mesh_io.h"
#include "testing/makehuman_fixture.h"
#include "testing/small_dataset.h"
#include "testing/test_meshes.h"

using namespace posekit;
namespace fs = std::filesystem;

namespace {

/// The shared small dataset (testing/small_dataset.h) with its manifest.
struct SmallDataset {
  std::string root;
  nlohmann::json manifest;
  SmallDataset() : root(test::small_dataset().root) { manifest = nlohmann::json::parse(read_file_bytes(root + "/manifest.json")); }
};

const SmallDataset& small_dataset() {
  static SmallDataset ds;
  return ds;
}

}  // namespace

TEST(Dataset, ManifestListsExactlyTheFilesWritten) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const auto& ds = small_dataset();
  std::set<std::string> listed;
  for (const auto& f : ds.manifest["files"]) {
    listed.insert(f["path"].get<std::string>());
    EXPECT_TRUE(fs::is_regular_file(ds.root + "/" + f["path"].get<std::string>())) << f["path"];
    EXPECT_FALSE(f["meaning"].get<std::string>().empty());
  }
  int on_disk = 0;
  for (const auto& e : fs::recursive_directory_iterator(ds.root))
    if (e.is_regular_file() && e.path().filename() != "manifest.json") {
      ++on_disk;
      EXPECT_TRUE(listed.count(fs::relative(e.path(), ds.root).string())) << e.path();
    }
  EXPECT_EQ(on_disk, static_cast<int>(listed.size()));
  // Made by another process under CTest: no temporary folder of any process is left beside it.
  const std::string prefix = fs::path(ds.root).filename().string() + ".tmp-";
  for (const auto& e : fs::directory_iterator(fs::path(ds.root).parent_path()))
    EXPECT_NE(e.path().filename().string().rfind(prefix, 0), 0u) << e.path();
}

TEST(Dataset, PoseMeshesShareTheTemplateTopologyAndTheSplitHoldsOutAFifth) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const auto& ds = small_dataset();
  const TriangleMesh templ = read_mesh(ds.root + "/template/rest.ply");
  EXPECT_EQ(templ.num_vertices(), 13380);
  const PoseDataset poses = load_pose_dataset(ds.root);
  EXPECT_EQ(poses.F, templ.F);
  int test_count = 0;
  for (size_t i = 0; i < poses.names.size(); ++i) {
    EXPECT_EQ(poses.V[i].rows(), 13380);
    EXPECT_TRUE(poses.has_pose[i]);
    test_count += poses.test[i];
  }
  EXPECT_GE(test_count * 5, static_cast<int>(poses.names.size()));
  EXPECT_EQ(poses.rest_name, "rest");
  // The rest example is the template itself.
  const auto rest = std::find(poses.names.begin(), poses.names.end(), "rest") - poses.names.begin();
  EXPECT_LT((poses.V[rest] - templ.V).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Dataset, SubjectsHaveTheirOwnManifoldTopologyAndExactCorrespondence) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const auto& ds = small_dataset();
  const TriangleMesh templ = read_mesh(ds.root + "/template/rest.ply");
  for (const auto& s : ds.manifest["subjects"]) {
    const std::string id = s["id"];
    const TriangleMesh rest = read_mesh(ds.root + "/" + s["rest"].get<std::string>());
    const MeshReport r = validate_mesh(rest);
    EXPECT_TRUE(r.watertight) << id;
    EXPECT_EQ(r.components, 1) << id;
    EXPECT_NEAR(rest.num_vertices(), 12400, 300) << id;
    EXPECT_NE(rest.num_vertices(), templ.num_vertices());
    // Ground truth: every subject vertex, evaluated on the subject-shaped template, within 1 mm.
    const Body body = build_body(model, read_body_spec(ds.root + "/" + s["spec"].get<std::string>()));
    const SurfacePoints corr = load_correspondence(ds.root + "/" + s["correspondence"].get<std::string>());
    ASSERT_EQ(corr.face.size(), rest.num_vertices());
    EXPECT_LT((evaluate_smooth_surface_points(body.mesh.V, body.mesh.F, vertex_normals(body.mesh.V, body.mesh.F), corr) - rest.V)
                  .rowwise()
                  .norm()
                  .maxCoeff(),
              0.001)
        << id;
    // Posed meshes keep the subject's topology.
    ASSERT_EQ(s["posed"].size(), 3u);
    for (const auto& p : s["posed"]) {
      const TriangleMesh posed = read_mesh(ds.root + "/" + p["mesh"].get<std::string>());
      EXPECT_EQ(posed.F, rest.F);
      EXPECT_GT((posed.V - rest.V).rowwise().norm().maxCoeff(), 0.1) << p["pose"];
    }
  }
}

TEST(Dataset, ScansLieWithinThreeSigmaOfTheSubjectApartFromDeclaredOutliers) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const auto& ds = small_dataset();
  const auto& s = ds.manifest["subjects"][0];
  const TriangleMesh rest = read_mesh(ds.root + "/" + s["rest"].get<std::string>());
  const auto& scan_entry = s["scans"][0];
  ASSERT_EQ(scan_entry["pose"], "rest");
  const PointCloud scan = load_scan(ds.root + "/" + scan_entry["cloud"].get<std::string>());  // millimetres
  EXPECT_GE(scan.size(), 200000);
  EXPECT_LE(scan.size(), 1000000);
  const SurfacePoints sp = closest_surface_points(rest, scan.P);
  const Eigen::VectorXd& outlier = scan.point_scalars.at("outlier");
  EXPECT_EQ(static_cast<int>(outlier.sum()), scan_entry["outliers"].get<int>());
  int beyond = 0;
  for (Eigen::Index i = 0; i < scan.size(); ++i) beyond += outlier[i] == 0 && sp.distance[i] > 0.005;
  EXPECT_LT(beyond, scan.size() / 200) << beyond << " inliers beyond 5 mm";
}

TEST(Dataset, PhotoSilhouettesMatchTheGroundTruthMasks) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const auto& ds = small_dataset();
  for (const auto& s : ds.manifest["subjects"])
    for (const char* view : {"front", "side"}) {
      int w = 0, h = 0, mw = 0, mh = 0;
      const auto photo = read_gray_png(ds.root + "/" + s["photos"][view].get<std::string>(), &w, &h);
      const auto mask = read_gray_png(ds.root + "/" + s["photos"][std::string(view) + "_mask"].get<std::string>(), &mw, &mh);
      ASSERT_EQ(w, mw);
      ASSERT_GE(h, 1000);
      long both = 0, either = 0;
      for (size_t k = 0; k < photo.size(); ++k) {
        const bool body = photo[k] != 235, in_mask = mask[k] == 255;
        both += body && in_mask;
        either += body || in_mask;
      }
      EXPECT_EQ(both, either) << view;  // identical silhouettes
      EXPECT_GT(both, static_cast<long>(photo.size()) / 20) << view;
    }
}

TEST(Dataset, SameSeedGivesByteIdenticalFiles) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const auto& ds = small_dataset();
  test::TempDir dir;
  DatasetOptions o;
  o.data_root = test::test_data_root();
  o.small = true;
  make_dataset(dir.file("again"), o);
  int compared = 0;
  for (const auto& e : fs::recursive_directory_iterator(ds.root)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), ds.root).string();
    const bool identical = read_file_bytes(e.path().string()) == read_file_bytes(dir.file("again/" + rel));
    ASSERT_TRUE(identical) << rel << " differs between two runs with the same seed";
    ++compared;
  }
  EXPECT_GT(compared, 50);
}

TEST(Dataset, BadInputLeavesNothingBehind) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  test::TempDir dir;
  DatasetOptions o;
  o.data_root = test::test_data_root();
  o.small = true;
  fs::create_directories(dir.file("exists"));
  EXPECT_THROW(make_dataset(dir.file("exists"), o), IoError);
  EXPECT_THROW(make_dataset("/proc/posekit-cannot-write-here/ds", o), IoError);
  o.data_root = dir.path();  // no assets
  EXPECT_THROW(make_dataset(dir.file("no-data"), o), IoError);
  EXPECT_EQ(dir.count(), 1);  // only "exists"
}

TEST(Dataset, UserFolderWithMismatchedTopologyIsNamed) {
  test::TempDir dir;
  const TriangleMesh a = test::icosphere(2), b = test::icosphere(3);
  write_mesh(dir.file("pose_a.ply"), a);
  write_mesh(dir.file("pose_b.obj"), a);
  EXPECT_EQ(load_pose_dataset(dir.path()).names.size(), 2u);
  write_mesh(dir.file("pose_c.ply"), b);
  try {
    load_pose_dataset(dir.path());
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("pose_c.ply"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load_pose_dataset(dir.file("missing")), IoError);
}

TEST(Subjects, SixteenSubjectsFillTheFourBmiClassesTwiceForEachGender) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const auto specs = make_subject_specs(model, 1, 16);
  std::map<std::pair<bool, BmiClass>, int> count;
  for (const auto& s : specs) {
    const BodyStats st = body_stats(build_body(model, s.spec).mesh);
    EXPECT_EQ(bmi_class_of(st.bmi), s.target_class) << s.id << " BMI " << st.bmi;
    EXPECT_EQ(s.spec.gender, s.female ? 0.0 : 1.0);
    ++count[{s.female, bmi_class_of(st.bmi)}];
  }
  for (bool female : {true, false})
    for (int c = 0; c < 4; ++c) EXPECT_EQ((count[{female, static_cast<BmiClass>(c)}]), 2);
  // No two subjects share proportions.
  for (size_t i = 0; i < specs.size(); ++i)
    for (size_t j = i + 1; j < specs.size(); ++j) EXPECT_NE(specs[i].spec.modifiers, specs[j].spec.modifiers);
  // One subject made alone is that subject, to the bit.
  for (int k : {0, 9, 15}) {
    const SubjectSpec one = make_subject_spec(model, 1, k);
    EXPECT_EQ(one.id, specs[static_cast<size_t>(k)].id);
    EXPECT_EQ(one.target_bmi, specs[static_cast<size_t>(k)].target_bmi);
    EXPECT_EQ(body_spec_to_json(one.spec), body_spec_to_json(specs[static_cast<size_t>(k)].spec)) << k;
  }
  EXPECT_THROW(make_subject_spec(model, 1, 16), InvalidInput);
}

TEST(Subjects, GroundTruthGirthsAreOrderedLikeBodies) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  for (double g : {0.0, 1.0})
    for (double w : {0.0, 1.0}) {
      BodySpec s;
      s.gender = g;
      s.weight = w;
      const Body b = build_body(model, s);
      const Measurements m = measure_makehuman_body(model, b);
      EXPECT_LT(m.underbust, m.bust);
      EXPECT_LT(m.waist, m.hip);
      EXPECT_LT(m.thigh, m.hip);
      EXPECT_LT(m.upper_arm, m.thigh);
      EXPECT_LT(m.neck, m.waist);
      EXPECT_GT(m.bust_height, m.waist_height);
      EXPECT_GT(m.waist_height, m.hip_height);
      EXPECT_GT(m.hip_height, m.crotch_height);
      EXPECT_NEAR(m.stature, b.mesh.V.col(1).maxCoeff() - b.mesh.V.col(1).minCoeff(), 1e-12);
    }
}
