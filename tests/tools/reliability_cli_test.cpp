// Nothing lost, nothing silently wrong: batch resume keyed on content, result names that cannot
// collide, killed runs' temporaries removed, a failed write that stops the run, and filesystem
// refusals reported as errors naming the path.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "posekit/io/atomic_file.h"
#include "testing/temp_dir.h"
#include "tools/cli_runner.h"

namespace posekit {
namespace {

namespace fs = std::filesystem;
using test::run_posekit;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// Two MakeHuman bodies of different stature, a.ply (taller) and b.ply.
void make_two_bodies(const test::TempDir& dir) {
  ASSERT_EQ(run_posekit("body --height 0.7 --out " + dir.file("a.ply")).code, 0);
  ASSERT_EQ(run_posekit("body --height 0.2 --gender 0 --out " + dir.file("b.ply")).code, 0);
}

TEST(CliReliability, BatchResumeKeysOnContentAndNamesCannotCollide) {
  ASSERT_FALSE(test::test_data_root().empty());
  test::TempDir dir;
  make_two_bodies(dir);
  // x_y/body.ply and x/y_body.ply once mapped to the same result name.
  fs::create_directories(dir.file("in/x_y"));
  fs::create_directories(dir.file("in/x"));
  fs::copy_file(dir.file("a.ply"), dir.file("in/x_y/body.ply"));
  fs::copy_file(dir.file("b.ply"), dir.file("in/x/y_body.ply"));
  const std::string batch = "batch measure --inputs " + dir.file("in") + " --out " + dir.file("out") + " --jobs 2";
  test::CommandResult r = run_posekit(batch);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "2 inputs, 2 processed, 0 done earlier, 0 failed")) << r.out;
  int results = 0;
  for (const auto& e : fs::directory_iterator(dir.file("out/results"))) results += e.path().extension() == ".json";
  EXPECT_EQ(results, 2);
  r = run_posekit(batch);
  EXPECT_TRUE(contains(r.out, "2 inputs, 0 processed, 2 done earlier")) << r.out;
  // Another body under the same name is measured again; the other input is not.
  fs::copy_file(dir.file("a.ply"), dir.file("in/x/y_body.ply"), fs::copy_options::overwrite_existing);
  // Killed runs leave temporaries: removed at the next run.
  dir.write("out/results/z.json.tmp-99999999", "{");
  dir.write("out/summary.json.tmp-localhost_gone-99999998-3", "{");
  r = run_posekit(batch, true);
  EXPECT_TRUE(contains(r.out, "2 inputs, 1 processed, 1 done earlier, 0 failed")) << r.out;
  EXPECT_TRUE(contains(r.out, "removed 1 temporary file(s) of killed runs")) << r.out;
  EXPECT_FALSE(fs::exists(dir.file("out/results/z.json.tmp-99999999")));
  const auto summary = nlohmann::json::parse(read_file_bytes(dir.file("out/summary.json")));
  ASSERT_EQ(summary["results"].size(), 2u);
  EXPECT_DOUBLE_EQ(summary["results"][0]["stature"].get<double>(), summary["results"][1]["stature"].get<double>())
      << "the replaced input kept the old body's result";
}

TEST(CliReliability, BatchWritesItsSummaryWhenAnInputsNameIsNotUtf8) {
  test::TempDir dir;
  // A Latin-1 file name in a failed input's message: the JSON writer replaces the byte.
  fs::create_directories(dir.file("in"));
  dir.write("in/caf\xe9.ply", "ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n");
  const test::CommandResult r = run_posekit("batch measure --inputs " + dir.file("in") + " --out " + dir.file("out"), true);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "1 inputs, 1 processed, 0 done earlier, 1 failed")) << r.out;
  EXPECT_FALSE(contains(r.out, "internal error")) << r.out;
  const auto summary = nlohmann::json::parse(read_file_bytes(dir.file("out/summary.json")));
  EXPECT_FALSE(summary["results"][0]["ok"].get<bool>());
}

TEST(CliReliability, BatchStopsAtTheFirstFailedWriteWithTheSystemsReason) {
  ASSERT_FALSE(test::test_data_root().empty());
  test::TempDir dir;
  make_two_bodies(dir);
  fs::create_directories(dir.file("in"));
  fs::copy_file(dir.file("a.ply"), dir.file("in/a.ply"));
  fs::copy_file(dir.file("b.ply"), dir.file("in/b.ply"));
  // No file may grow (as on a full disk): the first result cannot be written.
  const test::CommandResult r = run_posekit("batch measure --inputs " + dir.file("in") + " --out " + dir.file("out") + " --jobs 1", true,
                                            "trap '' XFSZ; ulimit -f 0; ");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "stopped at the first failed write (0 of 2 inputs done")) << r.out;
  EXPECT_TRUE(contains(r.out, "File too large")) << r.out;
  EXPECT_FALSE(contains(r.out, "internal error")) << r.out;
  for (const auto& e : fs::recursive_directory_iterator(dir.file("out")))
    EXPECT_FALSE(is_atomic_temporary_name(e.path().filename().string())) << e.path();
}

TEST(CliReliability, OutputsIntoMissingOrReadOnlyFoldersAreErrorsNamingThem) {
  test::TempDir dir;
  dir.write("tri.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  // A typo in a path is an error, not a new folder tree.
  test::CommandResult r = run_posekit("convert " + dir.file("tri.ply") + " " + dir.file("typo/dir/x.obj"), true);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "the folder " + dir.file("typo/dir") + " does not exist (create it first, or pass --mkdir)")) << r.out;
  EXPECT_FALSE(fs::exists(dir.file("typo")));
  r = run_posekit("convert " + dir.file("tri.ply") + " " + dir.file("typo/dir/x.obj") + " --mkdir", true);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir.file("typo/dir/x.obj")));
  // A batch's folder is created, its parent must exist.
  r = run_posekit("batch measure --inputs " + dir.file("tri.ply") + " --out " + dir.file("no/such/out"), true);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "does not exist")) << r.out;
  // A read-only filesystem (a tmpfs mounted read-only, where this machine allows it).
  fs::create_directories(dir.file("ro"));
  if (std::system(("mount -t tmpfs -o ro,size=1m tmpfs " + dir.file("ro") + " 2>/dev/null").c_str()) != 0)
    GTEST_SKIP() << "cannot mount a read-only tmpfs here (not root, or no mount permission)";
  r = run_posekit("convert " + dir.file("tri.ply") + " " + dir.file("ro/x.ply"), true);
  const test::CommandResult batch = run_posekit("batch measure --inputs " + dir.file("tri.ply") + " --out " + dir.file("ro/out"), true);
  std::system(("umount " + dir.file("ro")).c_str());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, dir.file("ro/x.ply") + ": cannot open for writing (Read-only file system)")) << r.out;
  EXPECT_EQ(batch.code, 1) << batch.out;
  EXPECT_TRUE(contains(batch.out, dir.file("ro/out/results") + ": cannot create the folder (Read-only file system)")) << batch.out;
  EXPECT_FALSE(contains(batch.out, "internal error")) << batch.out;
}

TEST(CliReliability, AShortBvhFrameLineAndAnEmptyCloudAreRefusedNamingThem) {
  test::TempDir dir;
  dir.write("short.bvh",
            "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n"
            "  End Site\n  {\n    OFFSET 0 1 0\n  }\n}\nMOTION\nFrames: 3\nFrame Time: 0.0333333\n1 2 3\n4 5\n6 7 8 9\n");
  test::CommandResult r = run_posekit("info " + dir.file("short.bvh"), true);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "short.bvh:15: frame 2 of 3 has 2 values, expected 3")) << r.out;
  dir.write("empty.ply", "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n");
  for (const char* command : {"info", "measure"}) {
    r = run_posekit(std::string(command) + " " + dir.file("empty.ply"), true);
    EXPECT_EQ(r.code, 1) << command << ": " << r.out;
    EXPECT_TRUE(contains(r.out, "empty.ply: no points")) << command << ": " << r.out;
  }
}

}  // namespace
}  // namespace posekit
