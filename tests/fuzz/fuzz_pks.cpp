// libFuzzer target: the .pks shape space reader. Every input is read twice: as it is, and with its
// CRC-32 appended, so that mutants pass the checksum and reach the header and section checks.
#include <string>

#include "fuzz_input.h"
#include "posekit/io/checksum.h"
#include "posekit/registration/shape_space.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string sealed(reinterpret_cast<const char*>(data), size);
  const std::uint32_t crc = posekit::crc32(sealed.data(), sealed.size());
  for (int k = 0; k < 4; ++k) sealed.push_back(static_cast<char>((crc >> (8 * k)) & 0xFFu));
  for (const std::string& bytes : {std::string(reinterpret_cast<const char*>(data), size), sealed}) {
    const std::string path = posekit::fuzz::write_input(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), ".pks");
    posekit::fuzz::expect_clean([&] { (void)posekit::read_shape_space(path); });
  }
  return 0;
}
