// A corpus of broken files generated here: each must raise IoError naming the file and the problem.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

#include "posekit/core/error.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "testing/bytes_of.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

using namespace posekit;
using posekit::test::bytes_of;

namespace {

std::string binary_ply_header(int nv, int nf) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(nv) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(nf) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string one_binary_triangle(int i0, int i1, int i2, float x0 = 0) {
  std::string s = binary_ply_header(3, 1);
  for (float v : {x0, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) s += bytes_of(v);
  s += bytes_of<std::uint8_t>(3) + bytes_of<std::int32_t>(i0) + bytes_of<std::int32_t>(i1) + bytes_of<std::int32_t>(i2);
  return s;
}

struct BadFile {
  const char* name;  // test name and file name stem
  const char* ext;
  std::string content;
  const char* expected;  // a phrase the message must contain
};

std::vector<BadFile> corpus() {
  const std::string ply_ascii_head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string pcd_head =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\n"
      "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\n";
  return {
      {"obj_empty", ".obj", "", "no vertices"},
      {"obj_nan", ".obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", ":2: non-finite"},
      {"obj_index_out_of_range", ".obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", ":4: face vertex index 9 out of range"},
      {"obj_negative_index", ".obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -7 1 2\n", "out of range"},
      {"obj_zero_index", ".obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "out of range"},
      {"obj_truncated_vertex", ".obj", "v 0 0 0\nv 1 0", ":2: expected 'v x y z"},
      {"obj_word_for_number", ".obj", "v 0 zero 0\n", "expected a number"},
      {"obj_two_vertex_face", ".obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "at least 3"},
      {"obj_binary_garbage", ".obj", std::string("\x7f\x45\x4c\x46\x00\x01\xff\xfe", 8), "NUL"},
      {"ply_empty", ".ply", "", "not a PLY file"},
      {"ply_wrong_magic", ".ply", "plx\nformat ascii 1.0\nend_header\n", "not a PLY file"},
      {"ply_no_end_header", ".ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "end_header"},
      {"ply_no_format", ".ply", "ply\nelement vertex 0\nend_header\n", "no 'format'"},
      {"ply_unknown_type", ".ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n1\n", "unknown property type"},
      {"ply_claims_more_vertices_ascii", ".ply", ply_ascii_head + "0 0 0\n1 0 0\n", "truncated"},
      {"ply_claims_more_vertices_binary", ".ply", binary_ply_header(1000, 1) + std::string(40, '\0'), "truncated"},
      {"ply_truncated_face_list", ".ply", one_binary_triangle(0, 1, 2).substr(0, one_binary_triangle(0, 1, 2).size() - 5), "truncated"},
      {"ply_index_out_of_range", ".ply", one_binary_triangle(0, 1, 3), "vertex index 3 out of range"},
      {"ply_negative_index", ".ply", one_binary_triangle(0, -1, 2), "vertex index -1 out of range"},
      {"ply_nan_coordinate", ".ply", one_binary_triangle(0, 1, 2, std::nanf("")), "non-finite"},
      {"ply_ascii_word", ".ply", ply_ascii_head + "0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n", "expected a number"},
      {"ply_huge_list", ".ply", binary_ply_header(3, 1) + std::string(36, '\0') + "\xff" + std::string(8, '\0'), "truncated"},
      // Found by the PLY fuzz target: a float list length or index that is NaN or not whole.
      {"ply_nan_list_length", ".ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list float int vertex_indices\nend_header\n"
       "0 0 0\n1 0 0\n0 1 0\nnan 0 1 2\n",
       "implausible list length"},
      {"ply_fractional_index", ".ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list uchar float vertex_indices\n"
       "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 nan\n",
       "is not a whole number"},
      {"ply_no_xyz", ".ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float q\nend_header\n1\n", "no x, y, z"},
      {"off_wrong_header", ".off", "PFF\n3 1 0\n", "expected the header 'OFF'"},
      {"off_empty", ".off", "", "file ends early"},
      {"off_claims_more", ".off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n", "file ends early"},
      {"off_index_out_of_range", ".off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", "vertex index 5 out of range"},
      {"off_nan", ".off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", "non-finite"},
      {"off_huge_count", ".off", "OFF\n2000000000 1 0\n", "more than the file can hold"},
      {"stl_garbage", ".stl", "this is not an stl file at all", "not an STL file"},
      {"stl_empty", ".stl", "", "not an STL file"},
      {"stl_ascii_partial_facet", ".stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n", "facets of 3"},
      {"stl_binary_nan", ".stl",
       std::string(80, ' ') + bytes_of<std::uint32_t>(1) + std::string(12, '\0') + bytes_of(std::nanf("")) + std::string(32 + 2, '\0'),
       "non-finite"},
      {"pcd_width_times_height_overflows", ".pcd",
       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4294967296\n"
       "HEIGHT 4294967296\nDATA binary\n",
       "more points than any file can hold"},
      {"pcd_no_data", ".pcd", "VERSION 0.7\nFIELDS x y z\n", "no DATA"},
      {"pcd_truncated_binary", ".pcd", pcd_head + "DATA binary\n" + std::string(20, '\0'), "truncated"},
      {"pcd_truncated_ascii", ".pcd", pcd_head + "DATA ascii\n1 2 3\n", "truncated"},
      {"pcd_no_xyz", ".pcd", "FIELDS a b c\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
       "no x, y, z"},
      {"pcd_size_mismatch", ".pcd", "FIELDS x y z\nSIZE 4 4\n", "expected one per field"},
      {"pcd_bad_compressed", ".pcd",
       pcd_head + "DATA binary_compressed\n" + bytes_of<std::uint32_t>(8) + bytes_of<std::uint32_t>(36) + std::string(8, '\x55'),
       "decompress"},
      {"pcd_garbage", ".pcd", std::string("\x01\x02\x03\xff garbage\n", 13), "unexpected PCD header line"},
      {"xyz_empty", ".xyz", "", "no points"},
      {"xyz_inconsistent_columns", ".xyz", "1 2 3\n4 5 6 7 8 9\n", ":2: expected 3 values"},
      {"xyz_word", ".xyz", "1 2 three\n", "expected a number"},
      {"xyz_garbage", ".xyz", std::string("\x00\x01\x02", 3), "NUL"},
      {"bvh_empty", ".bvh", "", "expected HIERARCHY"},
      {"bvh_truncated_frames", ".bvh",
       "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n1 2 3\n4 5\n",
       "truncated"},
      {"bvh_bad_channel", ".bvh", "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Wrotation\n}\n", "unknown channel"},
      {"bvh_missing_motion", ".bvh", "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\n", "MOTION"},
  };
}

void PrintTo(const BadFile& b, std::ostream* os) { *os << b.name << b.ext; }

void read_any(const std::string& path, const std::string& ext) {
  if (ext == ".pcd" || ext == ".xyz") read_point_cloud(path);
  else if (ext == ".bvh") read_bvh(path);
  else read_mesh(path);
}

}  // namespace

class BadFileCorpus : public ::testing::TestWithParam<BadFile> {};

TEST_P(BadFileCorpus, RaisesIoErrorNamingFileAndProblem) {
  test::TempDir dir;
  const BadFile& bad = GetParam();
  const std::string path = dir.write(std::string(bad.name) + bad.ext, bad.content);
  try {
    read_any(path, bad.ext);
    FAIL() << "no exception for " << bad.name;
  } catch (const IoError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(bad.expected), std::string::npos) << "message: " << msg << "\nexpected to contain: " << bad.expected;
  }
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadFileCorpus, ::testing::ValuesIn(corpus()),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(BadFiles, MissingFileAndDirectoryAreIoErrors) {
  test::TempDir dir;
  EXPECT_THROW(read_mesh(dir.file("absent.ply")), IoError);
  EXPECT_THROW(read_mesh(dir.path() + "/"), IoError);
  EXPECT_THROW(read_point_cloud(dir.file("absent.pcd")), IoError);
}

TEST(BadFiles, RandomGarbageAndTruncatedFilesNeverCrash) {
  // Every reader, fed random bytes and every 97th prefix of valid files, either parses or throws IoError.
  test::TempDir dir;
  const TriangleMesh m = test::icosphere(1);
  PointCloud cloud;
  cloud.P = m.V;
  write_mesh(dir.file("v.ply"), m);
  write_mesh(dir.file("v.obj"), m);
  write_mesh(dir.file("v.off"), m);
  write_mesh(dir.file("v.stl"), m);
  write_point_cloud(dir.file("v.pcd"), cloud);
  write_point_cloud(dir.file("va.pcd"), cloud, {Unit::kMetre, CloudFormat::kAuto, false});
  std::mt19937 rng(7);
  int errors = 0, parsed = 0;
  for (const std::string ext : {".ply", ".obj", ".off", ".stl", ".pcd"}) {
    for (const std::string stem : {"v", "va"}) {
      std::ifstream in(dir.file(stem + ext), std::ios::binary);
      if (!in) continue;
      const std::string valid((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      for (size_t cut = 0; cut < valid.size(); cut += 97) {
        const std::string path = dir.write("cut" + ext, valid.substr(0, cut));
        try {
          read_any(path, ext);
          ++parsed;
        } catch (const IoError&) {
          ++errors;
        }
      }
    }
    for (int trial = 0; trial < 30; ++trial) {
      std::string junk(1 + rng() % 400, '\0');
      for (char& c : junk) c = static_cast<char>(rng());
      if (trial % 3 == 0 && ext == ".ply") junk = "ply\nformat binary_little_endian 1.0\n" + junk;
      const std::string path = dir.write("junk" + ext, junk);
      try {
        read_any(path, ext);
        ++parsed;
      } catch (const IoError&) {
        ++errors;
      }
    }
  }
  EXPECT_GT(errors, 100);
}
