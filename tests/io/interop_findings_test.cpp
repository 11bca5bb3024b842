// The findings of a 281-file interop run, each as the shape of file that showed it: what was read
// silently wrong, dropped without a word, or refused although valid.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

namespace posekit {
namespace {

namespace fs = std::filesystem;

bool any_contains(const std::vector<std::string>& lines, const std::string& text) {
  for (const auto& l : lines)
    if (l.find(text) != std::string::npos) return true;
  return false;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

// A Blender-style export: the normals are written in their own order and the faces pair them with
// the vertices through v//vn. Vertex i's normal points away from the tetrahedron's centre.
TEST(InteropFindings, ObjNormalsFollowTheFacesIndicesNotTheOrderOfTheVnLines) {
  test::TempDir dir;
  const Eigen::Matrix<double, 4, 3> V = (Eigen::Matrix<double, 4, 3>() << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1).finished();
  const Eigen::RowVector3d centre = V.colwise().mean();
  Eigen::Matrix<double, 4, 3> N;
  for (int i = 0; i < 4; ++i) N.row(i) = (V.row(i) - centre).normalized();
  const int vn_of_vertex[4] = {3, 1, 4, 2};  // 1-based vn line of each vertex
  std::string obj = "# Blender v3.6 OBJ File\no Tetra\n";
  for (int i = 0; i < 4; ++i) obj += "v " + std::to_string(V(i, 0)) + " " + std::to_string(V(i, 1)) + " " + std::to_string(V(i, 2)) + "\n";
  for (int line = 1; line <= 4; ++line)
    for (int i = 0; i < 4; ++i)
      if (vn_of_vertex[i] == line)
        obj += "vn " + std::to_string(N(i, 0)) + " " + std::to_string(N(i, 1)) + " " + std::to_string(N(i, 2)) + "\n";
  const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  obj += "s 1\n";
  for (const auto& f : faces) {
    obj += "f";
    for (int c : f) obj += " " + std::to_string(c + 1) + "//" + std::to_string(vn_of_vertex[c]);
    obj += "\n";
  }
  dir.write("tetra.obj", obj);
  std::vector<std::string> warnings;
  const TriangleMesh mesh = read_mesh(dir.file("tetra.obj"), {Unit::kMetre, MeshFormat::kAuto, &warnings});
  ASSERT_TRUE(mesh.has_normals()) << joined(warnings);
  for (int i = 0; i < 4; ++i) EXPECT_LT((mesh.N.row(i) - N.row(i)).norm(), 1e-5) << "vertex " << i;
  EXPECT_TRUE(warnings.empty()) << joined(warnings);
}

TEST(InteropFindings, ObjNormalsOfAFlatShadedMeshAreDroppedWithAWarning) {
  test::TempDir dir;
  // Two triangles sharing an edge, each with its own normal (a hard edge): a vertex has two.
  dir.write("flat.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.5\nvn 0 0 1\nvn 0 -0.4 0.9\n"
            "f 1//1 2//1 3//1\nf 2//2 4//2 3//2\n");
  std::vector<std::string> warnings;
  const TriangleMesh mesh = read_mesh(dir.file("flat.obj"), {Unit::kMetre, MeshFormat::kAuto, &warnings});
  EXPECT_FALSE(mesh.has_normals());
  EXPECT_TRUE(any_contains(warnings, "normals not kept: 2 face corners")) << joined(warnings);
}

TEST(InteropFindings, ObjColoursOnSomeVerticesOnlyAreNamedNotSilentlyDropped) {
  test::TempDir dir;
  dir.write("partial.obj", "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 1 0\nv 1 1 0\nv 2 0 0\nf 1 2 3\nf 2 4 3\nf 2 5 4\n");
  std::vector<std::string> warnings;
  const TriangleMesh mesh = read_mesh(dir.file("partial.obj"), {Unit::kMetre, MeshFormat::kAuto, &warnings});
  EXPECT_FALSE(mesh.has_colors());
  EXPECT_TRUE(any_contains(warnings, "vertex colours not kept: only 2 of 5 vertices")) << joined(warnings);
}

// One frame line misses a value and the next has one too many: the same number of values in all,
// which a reader of one stream of tokens takes for three good frames, shifting every channel.
TEST(InteropFindings, BvhFrameLinesEachHoldExactlyTheChannelCount) {
  test::TempDir dir;
  const std::string head =
      "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n"
      "  End Site\n  {\n    OFFSET 0 1 0\n  }\n}\nMOTION\nFrames: 3\nFrame Time: 0.0333333\n";
  dir.write("short.bvh", head + "1 2 3\n4 5\n6 7 8 9\n");
  try {
    read_bvh(dir.file("short.bvh"));
    FAIL() << "a frame line with a missing value was read";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("short.bvh:15: frame 2 of 3 has 2 values, expected 3"), std::string::npos) << e.what();
  }
  // One line more than 'Frames:' says: read as declared, the extra line named.
  dir.write("extra.bvh", head + "1 2 3\n4 5 6\n7 8 9\n10 11 12\n\n");
  std::vector<std::string> warnings;
  const BvhMotion m = read_bvh(dir.file("extra.bvh"), Unit::kMetre, &warnings);
  EXPECT_EQ(m.num_frames(), 3);
  EXPECT_DOUBLE_EQ(m.frames(2, 2), 9.0);
  EXPECT_TRUE(any_contains(warnings, "extra.bvh:17: 1 frame line(s) after the 3 the header declares")) << joined(warnings);
  // Frames on the frame-time line, and fewer lines than declared, are errors naming them.
  dir.write("joined.bvh", head.substr(0, head.size() - 1) + " 1 2 3\n4 5 6\n7 8 9\n");
  EXPECT_THROW(read_bvh(dir.file("joined.bvh")), IoError);
  dir.write("few.bvh", head + "1 2 3\n4 5 6\n");
  try {
    read_bvh(dir.file("few.bvh"));
    FAIL() << "two frames read as three";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("declares 3 frames ('Frames: 3'), the file has 2"), std::string::npos) << e.what();
  }
}

TEST(InteropFindings, PlyElementsInAnyOrderFaceBeforeVertex) {
  test::TempDir dir;
  dir.write("face_first.ply",
            "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
            "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
            "3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n");
  const TriangleMesh mesh = read_mesh(dir.file("face_first.ply"));
  ASSERT_EQ(mesh.F.rows(), 1);
  EXPECT_EQ(mesh.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_DOUBLE_EQ(mesh.V(1, 0), 1.0);
  // An index beyond the vertices is still refused, naming the face.
  dir.write("bad.ply",
            "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
            "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
            "3 0 1 7\n0 0 0\n1 0 0\n0 1 0\n");
  try {
    read_mesh(dir.file("bad.ply"));
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("element 'face' #0 of 1: vertex index 7 out of range 0..2"), std::string::npos) << e.what();
  }
}

TEST(InteropFindings, PlyFacePropertiesAreKeptAndWrittenBack) {
  test::TempDir dir;
  // A quad and a triangle with face colours (uchar) and a quality (float).
  dir.write("faces.ply",
            "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 2\nproperty list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\n"
            "property uchar blue\nproperty float quality\nend_header\n"
            "0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n4 0 1 2 3 200 10 20 0.5\n3 1 4 2 5 6 7 -1.25\n");
  const TriangleMesh mesh = read_mesh(dir.file("faces.ply"));
  ASSERT_EQ(mesh.F.rows(), 3);  // the quad in two triangles
  ASSERT_EQ(mesh.face_scalars.size(), 4u);
  EXPECT_EQ(mesh.face_scalars.at("red"), Eigen::Vector3d(200, 200, 5));
  EXPECT_EQ(mesh.face_scalars.at("quality"), Eigen::Vector3d(0.5, 0.5, -1.25));
  for (bool binary : {true, false}) {
    const std::string out = dir.file(binary ? "back_bin.ply" : "back_ascii.ply");
    write_mesh(out, mesh, {Unit::kMetre, MeshFormat::kAuto, binary});
    const TriangleMesh back = read_mesh(out);
    EXPECT_EQ(back.face_scalars, mesh.face_scalars) << out;
  }
  std::vector<std::string> warnings;
  write_mesh(dir.file("faces.obj"), mesh, {Unit::kMetre, MeshFormat::kAuto, true, &warnings});
  EXPECT_TRUE(any_contains(warnings, "OBJ cannot hold the face field(s) blue, green, quality, red")) << joined(warnings);
}

/// The PLY header's lines, up to end_header.
std::string ply_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string header, line;
  while (std::getline(in, line) && line != "end_header") header += line + "\n";
  return header;
}

TEST(InteropFindings, PlyFieldsAreFloatsNamedAsCloudCompareKeepsThem) {
  test::TempDir dir;
  TriangleMesh m = test::icosphere(1);
  const Eigen::Index n = m.V.rows();
  m.vertex_scalars["signed_distance_mm"] = Eigen::VectorXd::LinSpaced(n, -12.5, 30.25);
  m.vertex_scalars["covered"] = Eigen::VectorXd::Ones(n);
  m.vertex_scalars["vertex_id"] = Eigen::VectorXd::LinSpaced(n, 0, static_cast<double>(n - 1)).array() + 16777216.0;  // beyond 2^24
  m.vertex_scalars["gps_time"] = Eigen::VectorXd::LinSpaced(n, 1.7e9, 1.7e9 + 60.5);  // large values that vary little
  write_mesh(dir.file("m.ply"), m);
  const std::string header = ply_header(dir.file("m.ply"));
  // CloudCompare's command line keeps only scalar_* properties; float32 where it holds the values.
  EXPECT_NE(header.find("property float x\n"), std::string::npos) << header;
  EXPECT_NE(header.find("property float scalar_signed_distance_mm\n"), std::string::npos) << header;
  EXPECT_NE(header.find("property float scalar_covered\n"), std::string::npos) << header;
  EXPECT_NE(header.find("property double scalar_vertex_id\n"), std::string::npos) << header;  // 16777217 is not a float
  EXPECT_NE(header.find("property double scalar_gps_time\n"), std::string::npos) << header;   // float32: 128 s steps
  const TriangleMesh back = read_mesh(dir.file("m.ply"));
  EXPECT_EQ(back.vertex_scalars.at("vertex_id"), m.vertex_scalars.at("vertex_id"));
  EXPECT_EQ(back.vertex_scalars.at("covered"), m.vertex_scalars.at("covered"));
  EXPECT_LE((back.vertex_scalars.at("signed_distance_mm") - m.vertex_scalars.at("signed_distance_mm")).cwiseAbs().maxCoeff(), 31 * 1e-7);

  // Coordinates that float32 would move by over a micrometre (a survey's easting) stay double.
  PointCloud far;
  far.P = m.V.rowwise() + Eigen::RowVector3d(500000.0, 0, 0);
  write_point_cloud(dir.file("far.ply"), far);
  EXPECT_NE(ply_header(dir.file("far.ply")).find("property double x\n"), std::string::npos);
  EXPECT_EQ(read_point_cloud(dir.file("far.ply")).P, far.P);

  // Asked for, doubles everywhere.
  MeshWriteOptions wide;
  wide.double_precision = true;
  write_mesh(dir.file("wide.ply"), m, wide);
  EXPECT_EQ(ply_header(dir.file("wide.ply")).find("property float"), std::string::npos);

  // A file CloudCompare wrote: its scalar_ fields come back by their own names.
  dir.write("cc.ply",
            "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
            "property float scalar_Intensity\nproperty float C2M_signed_distances\nend_header\n0 0 0 7 0.5\n1 0 0 8 -0.5\n");
  const PointCloud cc = read_point_cloud(dir.file("cc.ply"));
  EXPECT_EQ(cc.point_scalars.count("Intensity"), 1u);
  EXPECT_EQ(cc.point_scalars.count("C2M_signed_distances"), 1u);
}

TEST(InteropFindings, PlyPerCornerTexcoordBecomesVertexUvOrAWarningAtSeams) {
  test::TempDir dir;
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nend_header\n"
      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
  dir.write("uv.ply", head + "3 0 1 2 6 0 0 1 0 1 1\n3 0 2 3 6 0 0 1 1 0 1\n");
  const TriangleMesh mesh = read_mesh(dir.file("uv.ply"));
  ASSERT_TRUE(mesh.has_uv());
  EXPECT_EQ(mesh.UV.row(2), Eigen::RowVector2d(1, 1));
  EXPECT_EQ(mesh.UV.row(3), Eigen::RowVector2d(0, 1));
  // MeshLab's fuze.ply shape: a vertex with two texture coordinates (a seam).
  dir.write("seam.ply", head + "3 0 1 2 6 0 0 1 0 1 1\n3 0 2 3 6 0 0 0.5 0.5 0 1\n");
  std::vector<std::string> warnings;
  const TriangleMesh seam = read_mesh(dir.file("seam.ply"), {Unit::kMetre, MeshFormat::kAuto, &warnings});
  EXPECT_FALSE(seam.has_uv());
  EXPECT_TRUE(any_contains(warnings, "texture coordinates not kept: 1 face corners")) << joined(warnings);
}

TEST(InteropFindings, PlyDiffuseColoursAreColours) {
  test::TempDir dir;
  dir.write("diffuse.ply",
            "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar diffuse_red\nproperty uchar diffuse_green\nproperty uchar diffuse_blue\nend_header\n"
            "0 0 0 255 128 0\n1 0 0 1 2 3\n");
  const PointCloud cloud = read_point_cloud(dir.file("diffuse.ply"));
  ASSERT_TRUE(cloud.has_colors());
  EXPECT_EQ(cloud.C(0, 1), 128);
  EXPECT_EQ(cloud.C(1, 2), 3);
  EXPECT_TRUE(cloud.point_scalars.empty());
}

TEST(InteropFindings, XyzSevenColumnsWithAConstantSeventhAreRgba) {
  test::TempDir dir;
  dir.write("rgba.xyz", "0 0 0 255 0 10 255\n1 0 0 0 200 20 255\n0 1 0 30 40 50 255\n");
  std::vector<std::string> warnings;
  const PointCloud cloud = read_point_cloud(dir.file("rgba.xyz"), {Unit::kMetre, CloudFormat::kAuto, &warnings});
  ASSERT_TRUE(cloud.has_colors()) << joined(warnings);
  EXPECT_EQ(cloud.C(0, 0), 255);
  EXPECT_EQ(cloud.C(1, 1), 200);
  EXPECT_EQ(cloud.C(2, 2), 50);
  ASSERT_EQ(cloud.point_scalars.count("alpha"), 1u);
  EXPECT_EQ(cloud.point_scalars.at("alpha")[0], 255);
  EXPECT_EQ(cloud.point_scalars.count("intensity"), 0u);
  EXPECT_TRUE(any_contains(warnings, "columns 4-6 as RGB colours (0..255) and column 7 as the scalar field alpha")) << joined(warnings);
  // A PTS file (a count line) keeps Leica's X Y Z I R G B when the seventh column varies.
  dir.write("scan.pts", "3\n0 0 0 -1200 10 20 30\n1 0 0 -800 40 50 60\n0 1 0 300 70 80 90\n");
  const PointCloud pts = read_point_cloud(dir.file("scan.pts"));
  ASSERT_TRUE(pts.has_colors());
  EXPECT_EQ(pts.C(1, 0), 40);
  EXPECT_EQ(pts.point_scalars.at("intensity")[0], -1200);
}

TEST(InteropFindings, EmptyCloudsAndMeshesAreRefusedWithNoPoints) {
  test::TempDir dir;
  dir.write("empty.ply", "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n");
  try {
    read_point_cloud(dir.file("empty.ply"));
    FAIL() << "an empty cloud was read";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("empty.ply: no points"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_mesh(dir.file("empty.ply")), IoError);
  dir.write("nan.xyz", "nan 0 0\n0 inf 0\n");
  try {
    read_point_cloud(dir.file("nan.xyz"));
    FAIL() << "a cloud of non-finite points was read";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("no points with finite coordinates (all 2"), std::string::npos) << e.what();
  }
}

// Two writes of one file at once (here nested, as two threads of a batch can be) each get their own
// temporary: with one name per process the second took the first's file away.
TEST(InteropFindings, AtomicWritesOfOneFileAtOnceEachGetTheirOwnTemporary) {
  test::TempDir dir;
  const std::string path = dir.file("result.json");
  write_file_atomically(path, [&](std::ostream& outer) {
    outer << "outer";
    write_file_atomically(path, [](std::ostream& inner) { inner << "inner"; });
  });
  EXPECT_EQ(read_file_bytes(path), "outer");
  for (const auto& e : fs::directory_iterator(dir.path())) EXPECT_FALSE(is_atomic_temporary_name(e.path().filename().string())) << e.path();
}

TEST(InteropFindings, StaleTemporariesOfDeadRunsAreRemovedOthersKept) {
  test::TempDir dir;
  char host[256] = {};
  ::gethostname(host, sizeof(host) - 1);
  std::string me(host);
  for (char& c : me)
    if (c == '/' || c == '-' || c == ' ') c = '_';
  const std::string pid = std::to_string(::getpid());
  dir.write("a.json.tmp-99999999", "old format, no such process");
  dir.write("b.json.tmp-" + me + "-99999998-0", "this host, no such process");
  dir.write("c.json.tmp-" + me + "-" + pid + "-7", "this process: still writing");
  dir.write("d.json.tmp-otherhost-123-0", "another host, fresh");
  dir.write("e.json.tmp-otherhost-124-0", "another host, two days old");
  fs::last_write_time(dir.file("e.json.tmp-otherhost-124-0"), fs::file_time_type::clock::now() - std::chrono::hours(48));
  dir.write("f.json", "a result");
  EXPECT_EQ(remove_stale_temporaries(dir.path()), 3);
  for (const char* kept : {"f.json", "d.json.tmp-otherhost-123-0"}) EXPECT_TRUE(fs::exists(dir.file(kept))) << kept;
  EXPECT_TRUE(fs::exists(dir.file("c.json.tmp-" + me + "-" + pid + "-7")));
  EXPECT_FALSE(fs::exists(dir.file("a.json.tmp-99999999")));
}

// A write the system refuses (here a file size limit, as a full disk refuses) names the reason and
// leaves nothing behind, neither the file nor its temporary.
TEST(InteropFindings, AFailedWriteNamesTheSystemsReasonAndLeavesNothing) {
  test::TempDir dir;
  const std::string path = dir.file("big.bin");
  struct rlimit old_limit {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit small = old_limit;
  small.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  try {
    write_file_atomically(path, [](std::ostream& out) { out << std::string(1 << 20, 'x'); });
  } catch (const WriteError& e) {
    message = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find("big.bin: write failed (File too large)"), std::string::npos) << message;
  EXPECT_TRUE(fs::is_empty(dir.path()));
  // A folder that does not exist is named, not created.
  try {
    write_file_atomically(dir.file("no/such/x.ply"), [](std::ostream& out) { out << "x"; });
    FAIL();
  } catch (const WriteError& e) {
    EXPECT_NE(std::string(e.what()).find("the folder " + dir.file("no/such") + " does not exist"), std::string::npos) << e.what();
  }
  EXPECT_THROW(require_output_folder(dir.file("no/such/x.ply")), IoError);
  EXPECT_FALSE(fs::exists(dir.file("no")));
  require_output_folder(dir.file("no/such/x.ply"), true);
  EXPECT_TRUE(fs::is_directory(dir.file("no/such")));
}

/// A .glb's JSON and binary chunks, read as the format says (little-endian headers).
struct Glb {
  nlohmann::json json;
  std::string bin;
  template <typename T>
  std::vector<T> values(int accessor) const {
    const auto& a = json["accessors"][static_cast<size_t>(accessor)];
    const auto& view = json["bufferViews"][a["bufferView"].get<size_t>()];
    std::vector<T> out(view["byteLength"].get<size_t>() / sizeof(T));
    std::memcpy(out.data(), bin.data() + view["byteOffset"].get<size_t>(), out.size() * sizeof(T));
    return out;
  }
};

Glb read_glb(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto u32 = [&](size_t at) {
    std::uint32_t v;
    std::memcpy(&v, bytes.data() + at, 4);
    return v;
  };
  EXPECT_EQ(bytes.substr(0, 4), "glTF");
  EXPECT_EQ(u32(4), 2u);
  EXPECT_EQ(u32(8), bytes.size());
  const std::uint32_t json_length = u32(12);
  EXPECT_EQ(bytes.substr(16, 4), "JSON");
  EXPECT_EQ(json_length % 4, 0u);
  Glb glb;
  glb.json = nlohmann::json::parse(bytes.substr(20, json_length));
  const size_t bin_at = 20 + json_length;
  EXPECT_EQ(bytes.substr(bin_at + 4, 4), std::string("BIN\0", 4));
  glb.bin = bytes.substr(bin_at + 8, u32(bin_at));
  return glb;
}

TEST(InteropFindings, GltfBinaryHoldsTheMeshColoursAndFieldsAsTheFormatSays) {
  test::TempDir dir;
  TriangleMesh m = test::icosphere(1, 0.5);
  const Eigen::Index n = m.V.rows();
  m.N = m.V.rowwise().normalized();
  m.C = RowMatrixX3u8::Constant(n, 3, 40);
  m.C.col(0).setConstant(200);
  m.UV = Eigen::MatrixXd::Constant(n, 2, 0.25);
  m.vertex_scalars["signed_distance_mm"] = Eigen::VectorXd::LinSpaced(n, -3, 4);
  m.face_scalars["quality"] = Eigen::VectorXd::Ones(m.F.rows());
  std::vector<std::string> warnings;
  MeshWriteOptions o;
  o.unit = Unit::kMillimetre;
  o.warnings = &warnings;
  write_mesh(dir.file("m.glb"), m, o);
  EXPECT_TRUE(any_contains(warnings, "glTF is in metres")) << joined(warnings);
  EXPECT_TRUE(any_contains(warnings, "glTF cannot hold the face field(s) quality")) << joined(warnings);
  const Glb glb = read_glb(dir.file("m.glb"));
  EXPECT_EQ(glb.json["asset"]["version"], "2.0");
  const auto& primitive = glb.json["meshes"][0]["primitives"][0];
  EXPECT_EQ(primitive["mode"], 4);
  const auto& attributes = primitive["attributes"];
  for (const char* a : {"POSITION", "NORMAL", "COLOR_0", "TEXCOORD_0", "_SIGNED_DISTANCE_MM"})
    ASSERT_TRUE(attributes.contains(a)) << a << ": " << attributes.dump();
  const std::vector<float> p = glb.values<float>(attributes["POSITION"]);
  ASSERT_EQ(p.size(), static_cast<size_t>(3 * n));
  for (Eigen::Index v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(p[static_cast<size_t>(3 * v + k)], static_cast<float>(m.V(v, k)));  // metres
  const auto& position = glb.json["accessors"][attributes["POSITION"].get<size_t>()];
  EXPECT_NEAR(position["max"][1].get<double>(), m.V.col(1).maxCoeff(), 1e-6);
  EXPECT_NEAR(position["min"][1].get<double>(), m.V.col(1).minCoeff(), 1e-6);
  const std::vector<std::uint8_t> c = glb.values<std::uint8_t>(attributes["COLOR_0"]);
  EXPECT_EQ(int(c[0]), 200);
  EXPECT_EQ(int(c[1]), 40);
  EXPECT_EQ(int(c[3]), 255);                                         // RGBA: every attribute element 4-byte aligned
  EXPECT_EQ(glb.values<float>(attributes["TEXCOORD_0"])[1], 0.75f);  // glTF's v runs down
  EXPECT_EQ(glb.values<float>(attributes["_SIGNED_DISTANCE_MM"])[0], -3.0f);
  const std::vector<std::uint32_t> indices = glb.values<std::uint32_t>(primitive["indices"]);
  ASSERT_EQ(indices.size(), static_cast<size_t>(3 * m.F.rows()));
  EXPECT_EQ(indices[4], static_cast<std::uint32_t>(m.F(1, 1)));
  for (const auto& view : glb.json["bufferViews"]) EXPECT_EQ(view["byteOffset"].get<size_t>() % 4, 0u);
  // Written, not read: reading names what to do.
  try {
    read_mesh(dir.file("m.glb"));
    ADD_FAILURE() << "a .glb was read";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("does not read it"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace posekit
