#pragma once
// One small generated dataset (`posekit dataset make --small`) per test binary, about 2 s.
#include <string>

#include "posekit/datasets/dataset.h"
#include "testing/temp_dir.h"

namespace posekit::test {

struct SmallDataset {
  TempDir dir;
  std::string root;
  SmallDataset() {
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
