#pragma once
// Plugins: the code that needs VTK, PCL or OpenCV is built into small shared objects loaded on first
// use, so a command that does not draw, run ICP or read photos does not load those libraries
// (posekit starts in milliseconds). The public functions keep their signatures; their bodies call
// the plugin. A plugin is libposekit_<name>_plugin.so, looked for in order in:
//   $POSEKIT_PLUGIN_DIR;
//   beside the binary that holds posekit's code (the CLI, a program, the Python module):
//     <its folder>/posekit_plugins and <its folder>/<bin-to-lib path>/posekit;
//   the build tree's plugin folder; the install prefix's <libdir>/posekit.
// A plugin built from another version of posekit is skipped.
#include <string>

namespace posekit {

/// The address of `symbol` in the plugin `name`, loaded on the first call (thread-safe). Throws
/// posekit::Error naming the plugin, every folder looked in and the loader's reason.
void* plugin_symbol(const std::string& name, const char* symbol);

/// plugin_symbol as a typed function pointer: `plugin_function<int(double)>("render", "posekit_f")`.
template <class Function>
Function* plugin_function(const std::string& name, const char* symbol) {
  return reinterpret_cast<Function*>(plugin_symbol(name, symbol));
}

/// The file the plugin `name` was (or would be) loaded from; empty when it cannot be found.
std::string plugin_path(const std::string& name);

}  // namespace posekit

/// Marks a plugin's entry points: C linkage, visible from the shared object.
#define POSEKIT_PLUGIN_EXPORT extern "C" __attribute__((visibility("default")))
