#include "posekit/core/data_root.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "posekit/core/error.h"
#include "testing/temp_dir.h"

using namespace posekit;

TEST(DataRoot, ExplicitFolderWithoutAssetsIsAClearError) {
  test::TempDir dir;
  try {
    find_data_root(dir.path());
    FAIL() << "no exception";
  } catch (const IoError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(dir.path()), std::string::npos);
    EXPECT_NE(msg.find("3dobjs/base.obj"), std::string::npos);
  }
}

TEST(DataRoot, ExplicitFolderWithAssetsIsChosen) {
  test::TempDir dir;
  std::filesystem::create_directories(dir.path() + "/3dobjs");
  dir.write("3dobjs/base.obj", "v 0 0 0\n");
  EXPECT_EQ(std::filesystem::path(find_data_root(dir.path())), std::filesystem::path(dir.path()));
}

TEST(DataRoot, EnvironmentVariableIsUsedAndCheckedWhenSet) {
  const char* old = std::getenv("POSEKIT_DATA");
  const std::string saved = old ? old : "";
  test::TempDir dir;
  ::setenv("POSEKIT_DATA", dir.path().c_str(), 1);
  EXPECT_THROW(find_data_root(), IoError);
  std::filesystem::create_directories(dir.path() + "/3dobjs");
  dir.write("3dobjs/base.obj", "v 0 0 0\n");
  EXPECT_EQ(std::filesystem::path(find_data_root()), std::filesystem::path(dir.path()));
  if (old) ::setenv("POSEKIT_DATA", saved.c_str(), 1);
  else ::unsetenv("POSEKIT_DATA");
}
