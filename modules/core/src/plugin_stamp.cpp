// Compiled into every plugin (posekit_add_plugin): the build it belongs to, checked by the loader.
#include "posekit/core/plugin.h"

POSEKIT_PLUGIN_EXPORT const char* posekit_plugin_build_stamp() { return POSEKIT_PLUGIN_STAMP; }
