#include "posekit/core/plugin.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <vector>

#include "posekit/core/error.h"

#ifndef POSEKIT_PLUGIN_STAMP
#error "POSEKIT_PLUGIN_STAMP must be defined by the build"
#endif
#ifndef POSEKIT_BUILD_PLUGIN_DIR
#define POSEKIT_BUILD_PLUGIN_DIR ""
#endif
#ifndef POSEKIT_INSTALL_PLUGIN_DIR
#define POSEKIT_INSTALL_PLUGIN_DIR ""
#endif
#ifndef POSEKIT_BIN_TO_PLUGIN_DIR
#define POSEKIT_BIN_TO_PLUGIN_DIR "../lib/posekit"
#endif

namespace posekit {
namespace fs = std::filesystem;

namespace {

std::mutex& plugin_mutex() {
  static std::mutex m;
  return m;
}

std::map<std::string, void*>& loaded_plugins() {
  static std::map<std::string, void*> handles;
  return handles;
}

/// The folders looked in, in order (see plugin.h).
std::vector<fs::path> plugin_folders() {
  std::vector<fs::path> folders;
  if (const char* env = std::getenv("POSEKIT_PLUGIN_DIR"); env && *env) folders.emplace_back(env);
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&plugin_folders), &info) != 0 && info.dli_fname && *info.dli_fname) {
    // The main program is named as it was started (maybe found on PATH); /proc/self/exe is exact.
    std::error_code ec;
    const std::string name(info.dli_fname);
    fs::path self = fs::canonical(name.find('/') == std::string::npos ? fs::path("/proc/self/exe") : fs::path(name), ec);
    if (ec) self = fs::canonical("/proc/self/exe", ec);
    if (!ec) {
      folders.push_back(self.parent_path() / "posekit_plugins");
      folders.push_back((self.parent_path() / POSEKIT_BIN_TO_PLUGIN_DIR).lexically_normal());
    }
  }
  if (*POSEKIT_BUILD_PLUGIN_DIR) folders.emplace_back(POSEKIT_BUILD_PLUGIN_DIR);
  if (*POSEKIT_INSTALL_PLUGIN_DIR) folders.emplace_back(POSEKIT_INSTALL_PLUGIN_DIR);
  std::vector<fs::path> distinct;
  for (const fs::path& f : folders)
    if (std::find(distinct.begin(), distinct.end(), f) == distinct.end()) distinct.push_back(f);
  return distinct;
}

std::string file_name(const std::string& name) { return "libposekit_" + name + "_plugin.so"; }

void* load_plugin(const std::string& name) {
  std::string reasons;
  for (const fs::path& folder : plugin_folders()) {
    const fs::path path = folder / file_name(name);
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
      reasons += "\n  " + path.string() + ": no such file";
      continue;
    }
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = dlerror();
      reasons += "\n  " + path.string() + ": " + (why ? why : "cannot be loaded");
      continue;
    }
    using Stamp = const char*();
    auto* stamp = reinterpret_cast<Stamp*>(dlsym(handle, "posekit_plugin_build_stamp"));
    if (!stamp || std::string(stamp()) != POSEKIT_PLUGIN_STAMP) {
      reasons += "\n  " + path.string() + ": built for " + (stamp ? stamp() : "an unknown build") + ", not this one (" +
                 POSEKIT_PLUGIN_STAMP + ")";
      dlclose(handle);
      continue;
    }
    return handle;
  }
  throw Error("posekit's " + name + " plugin (" + file_name(name) +
              ", installed with posekit in <libdir>/posekit) could not be loaded; it holds the code that uses VTK, "
              "PCL or OpenCV. Looked in (POSEKIT_PLUGIN_DIR names another folder):" +
              reasons);
}

}  // namespace

void* plugin_symbol(const std::string& name, const char* symbol) {
  std::lock_guard<std::mutex> lock(plugin_mutex());
  void*& handle = loaded_plugins()[name];
  if (!handle) handle = load_plugin(name);
  void* address = dlsym(handle, symbol);
  if (!address) throw Error("posekit's " + name + " plugin has no entry point " + symbol + ": it was built from other sources");
  return address;
}

std::string plugin_path(const std::string& name) {
  for (const fs::path& folder : plugin_folders()) {
    std::error_code ec;
    if (fs::is_regular_file(folder / file_name(name), ec)) return (folder / file_name(name)).string();
  }
  return {};
}

}  // namespace posekit
