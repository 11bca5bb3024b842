// libFuzzer target: the 16-part pose JSON reader.
#include "fuzz_input.h"
#include "posekit/body/parts.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  posekit::fuzz::expect_clean([&] { (void)posekit::part_pose_from_json(text, "fuzz.json"); });
  return 0;
}
