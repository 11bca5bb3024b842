// The fuzz targets' seed corpus (scripts/fuzz.sh): valid files of every format posekit reads, as
// posekit and other tools write them. Written to $POSEKIT_FUZZ_SEEDS/<target>/ when that is set;
// always checked to read without error, so a seed never starts the fuzzer on a rejected file.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>

#include "posekit/io/atomic_file.h"
#include "posekit/io/bvh.h"
#include "posekit/io/json.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

using namespace posekit;

namespace {

/// Where seeds of `target` go: $POSEKIT_FUZZ_SEEDS/<target>, or a folder of `fallback`.
std::string seed_dir(const test::TempDir& fallback, const std::string& target) {
  const char* root = std::getenv("POSEKIT_FUZZ_SEEDS");
  const std::string dir = (root && *root ? std::string(root) : fallback.path()) + "/" + target;
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace

TEST(FuzzSeeds, EveryReaderHasSeedsThatReadWithoutError) {
  test::TempDir tmp;
  TriangleMesh mesh = test::icosphere(1);
  mesh.N = mesh.V.rowwise().normalized();
  mesh.C = RowMatrixX3u8::Constant(mesh.V.rows(), 3, 200);
  mesh.UV = mesh.V.leftCols(2);
  mesh.vertex_scalars["error_mm"] = mesh.V.col(2);
  PointCloud cloud;
  cloud.P = mesh.V;
  cloud.N = mesh.N;
  cloud.C = mesh.C;
  cloud.point_scalars["intensity"] = mesh.V.col(0);
  int seeds = 0;
  auto check = [&](const std::string& path, const std::function<void()>& read) {
    SCOPED_TRACE(path);
    EXPECT_NO_THROW(read());
    ++seeds;
  };
  for (const std::string format : {"ply", "obj", "off", "stl"}) {
    const std::string dir = seed_dir(tmp, format);
    for (const bool binary : {true, false}) {
      if (!binary && format != "ply" && format != "stl") continue;
      const std::string path = dir + "/posekit_" + (binary ? "binary." : "ascii.") + format;
      write_mesh(path, mesh, {Unit::kMetre, MeshFormat::kAuto, binary});
      check(path, [&] { read_mesh(path); });
    }
  }
  const std::string ply = seed_dir(tmp, "ply");
  write_point_cloud(ply + "/cloud.ply", cloud, {Unit::kMillimetre, CloudFormat::kAuto, false});
  check(ply + "/cloud.ply", [&] { read_point_cloud(ply + "/cloud.ply"); });
  const std::string pcl_style = tmp.write("pcl.ply",
                                          "ply\nformat ascii 1.0\ncomment PCL generated\nelement vertex 2\n"
                                          "property float x\nproperty float y\nproperty float z\nelement face 0\n"
                                          "element camera 1\nproperty float view_px\nend_header\n1 2 3\n4 5 6\n0\n");
  std::filesystem::copy_file(pcl_style, ply + "/pcl.ply", std::filesystem::copy_options::overwrite_existing);
  check(ply + "/pcl.ply", [&] { read_point_cloud(ply + "/pcl.ply"); });
  const std::string obj = seed_dir(tmp, "obj");
  const std::string obj_text =
      "# seed\nmtllib a.mtl\no body\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv +1 1 0 1 1 1\n"
      "vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvn 0 0 1\ng torso\ns 1\nf 1/1/1 2/2/1 \\\n 3/3/1\ng arm\n"
      "f -1/-1/1 -3/-3/1 -2/-2/1\np 1\nl 1 2\n";
  std::filesystem::copy_file(tmp.write("hand.obj", obj_text), obj + "/hand.obj", std::filesystem::copy_options::overwrite_existing);
  check(obj + "/hand.obj", [&] { read_mesh(obj + "/hand.obj"); });
  const std::string off = seed_dir(tmp, "off");
  std::filesystem::copy_file(tmp.write("c.off",
                                       "CNOFF\n# comment\n4 2 0\n0 0 0 0 0 1 1 0 0 1\n1 0 0 0 0 1 0 1 0 1\n"
                                       "0 1 0 0 0 1 0 0 1 1\n1 1 0 0 0 1 1 1 1 1\n3 0 1 2\n4 0 1\n 3 2 255 0 0\n"),
                             off + "/c.off", std::filesystem::copy_options::overwrite_existing);
  check(off + "/c.off", [&] { read_mesh(off + "/c.off"); });
  const std::string pcd = seed_dir(tmp, "pcd");
  for (const std::string data : {"binary", "ascii"}) {
    const std::string path = pcd + "/posekit_" + data + ".pcd";
    write_point_cloud(path, cloud, {Unit::kMetre, CloudFormat::kAuto, data == "binary"});
    check(path, [&] { read_point_cloud(path); });
  }
  std::string compressed =
      "VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\n"
      "POINTS 2\nDATA binary_compressed\n";
  // 32 raw bytes as LZF literal runs (a control byte n-1, then n bytes).
  std::string raw;
  for (float v : {1.f, 2.f, 3.f, 4.f, 5.f, 6.f}) raw.append(reinterpret_cast<const char*>(&v), 4);
  raw += std::string("\x07\x80\xff\x00\x10\x20\x30\x00", 8);
  const std::string lzf = std::string(1, static_cast<char>(31)) + raw;
  const std::uint32_t csize = static_cast<std::uint32_t>(lzf.size()), usize = 32;
  compressed.append(reinterpret_cast<const char*>(&csize), 4).append(reinterpret_cast<const char*>(&usize), 4) += lzf;
  std::filesystem::copy_file(tmp.write("z.pcd", compressed), pcd + "/compressed.pcd", std::filesystem::copy_options::overwrite_existing);
  check(pcd + "/compressed.pcd", [&] { read_point_cloud(pcd + "/compressed.pcd"); });
  const std::string xyz = seed_dir(tmp, "xyz");
  write_point_cloud(xyz + "/posekit.xyz", cloud, {Unit::kMillimetre});
  check(xyz + "/posekit.xyz", [&] { read_point_cloud(xyz + "/posekit.xyz"); });
  for (const auto& [name, text] : {std::pair<std::string, std::string>{"leica.pts", "2\n1 2 3 -100 10 20 30\n4 5 6 50 40 50 60\n"},
                                   {"rgb.xyz", "0.1;0.2;0.3;255;0;12\n1,2,3,0,128,255\n"},
                                   {"header.xyz", "X Y Z Intensity\n1 2 3 0.5\nnan nan nan 0\n"}}) {
    const std::string path = xyz + "/" + name;  // a structured binding cannot be captured in C++17
    std::filesystem::copy_file(tmp.write(name, text), path, std::filesystem::copy_options::overwrite_existing);
    check(path, [&] { read_point_cloud(path); });
  }
  const std::string bvh = seed_dir(tmp, "bvh");
  const std::string motion =
      "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 90 0\n\tCHANNELS 6 Xposition Yposition Zposition "
      "Zrotation Xrotation Yrotation\n\tJOINT LeftUpLeg\n\t{\n\t\tOFFSET 10 0 0\n\t\tCHANNELS 3 "
      "Zrotation Yrotation Xrotation\n\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 -40 0\n\t\t}\n\t}\n}\n"
      "MOTION\nFrames: 2\nFrame Time: 0.0083333\n0 90 0 0 0 0 10 -5 2\n1 91 0 5 0 0 12 -5 +2e1\n";
  std::filesystem::copy_file(tmp.write("cmu.bvh", motion), bvh + "/cmu.bvh", std::filesystem::copy_options::overwrite_existing);
  check(bvh + "/cmu.bvh", [&] { read_bvh(bvh + "/cmu.bvh", Unit::kCentimetre); });
  const std::string pose = seed_dir(tmp, "pose_json");
  for (const auto& [name, text] :
       {std::pair<std::string, std::string>{"pose.json", R"({"format": "posekit 16-part pose 1", "joints": {"left_knee": [1.2, 0, 0],
 "right_hip": [0, 0.1, -0.2]}, "root_rotation": [0, 0, 0], "root_translation": [0, 0.05, 0]})"},
        {"empty.json", R"({"joints": {}})"}}) {
    const std::string path = pose + "/" + name, &body = text;
    write_file_atomically(
        path, [&](std::ostream& out) { out << body; }, false);
    check(path, [&] { parse_json(read_file_bytes(path), path); });
  }
  EXPECT_GE(seeds, 17);
}
