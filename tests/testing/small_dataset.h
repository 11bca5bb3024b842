#pragma once
// One small generated dataset (`posekit dataset make --small`), about 2 s (15 s under ASan). Under
// CTest it is made once per run by the SmallDatasetForTests fixture and shared through
// POSEKIT_TEST_SMALL_DATASET (tests only read it); a test binary run by hand makes its own.
#include <cstdlib>
#include <filesystem>
#include <string>

#include "posekit/datasets/dataset.h"
#include "testing/temp_dir.h"

namespace posekit::test {

struct SmallDataset {
  TempDir dir;
  std::string root;
  SmallDataset() {
    const char* shared = std::getenv("POSEKIT_TEST_SMALL_DATASET");
    if (shared && std::filesystem::is_regular_file(std::string(shared) + "/manifest.json")) {
      root = shared;
      return;
    }
    root = dir.file("small");
    DatasetOptions o;
    o.data_root = test_data_root();
    o.small = true;
    make_dataset(root, o);
  }
};

/// Built on first use; empty root when the MakeHuman data is missing (make_dataset throws then).
inline const SmallDataset& small_dataset() {
  static SmallDataset ds;
  return ds;
}

}  // namespace posekit::test
