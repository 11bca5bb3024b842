#include "posekit/core/plugin.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "posekit/core/error.h"
#include "testing/temp_dir.h"

using namespace posekit;

namespace {

/// Sets an environment variable for the scope of a test.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old, had_ = true;
    setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (had_) setenv(name_, old_.c_str(), 1);
    else unsetenv(name_);
  }

 private:
  const char* name_;
  std::string old_;
  bool had_ = false;
};

}  // namespace

TEST(Plugin, AMissingPluginNamesItselfAndEveryFolderLookedIn) {
  test::TempDir dir;
  const ScopedEnv env("POSEKIT_PLUGIN_DIR", dir.path());
  try {
    plugin_symbol("no_such", "posekit_anything");
    FAIL() << "no exception";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("libposekit_no_such_plugin.so"), std::string::npos) << msg;
    EXPECT_NE(msg.find(dir.path()), std::string::npos) << msg;
    EXPECT_NE(msg.find("POSEKIT_PLUGIN_DIR"), std::string::npos) << msg;
  }
  EXPECT_EQ(plugin_path("no_such"), "");
}

TEST(Plugin, AFileThatIsNotAPluginIsSkippedForTheNextFolder) {
  // A broken copy first on the search path: its reason is kept, the build's own plugin is used.
  test::TempDir dir;
  dir.write("libposekit_render_plugin.so", "not a shared object");
  const ScopedEnv env("POSEKIT_PLUGIN_DIR", dir.path());
  EXPECT_EQ(plugin_path("render"), dir.file("libposekit_render_plugin.so"));
  EXPECT_NE(plugin_symbol("render", "posekit_render_panels_png"), nullptr);
  EXPECT_THROW(plugin_symbol("render", "posekit_no_such_entry"), Error);
}
