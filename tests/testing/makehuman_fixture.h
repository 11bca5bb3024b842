#pragma once
// The MakeHuman model, loaded once per test binary from POSEKIT_DATA.
#include <gtest/gtest.h>

#include <memory>

#include "posekit/body/makehuman_model.h"
#include "testing/temp_dir.h"

namespace posekit::test {

inline std::shared_ptr<const MakeHumanModel> makehuman() {
  static std::shared_ptr<const MakeHumanModel> model = [] {
    const std::string root = test_data_root();
    return root.empty() ? nullptr : load_makehuman_model(root);
  }();
  return model;
}

#define POSEKIT_REQUIRE_MAKEHUMAN()                                                       \
  const auto model_ptr = ::posekit::test::makehuman();                                    \
  ASSERT_NE(model_ptr, nullptr) << "POSEKIT_DATA does not point at the MakeHuman assets"; \
  [[maybe_unused]] const ::posekit::MakeHumanModel& model = *model_ptr

}  // namespace posekit::test
