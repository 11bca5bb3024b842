#include "posekit/io/checksum.h"

#include <gtest/gtest.h>

#include <string>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "testing/temp_dir.h"

using namespace posekit;

TEST(Checksum, Crc32MatchesTheStandardCheckValueAndContinues) {
  const std::string text = "123456789";
  EXPECT_EQ(crc32(text.data(), text.size()), 0xCBF43926u);  // the CRC-32/ISO-HDLC check value
  EXPECT_EQ(crc32(text.data() + 4, 5, crc32(text.data(), 4)), 0xCBF43926u);
  EXPECT_EQ(crc32(nullptr, 0), 0u);
}

TEST(Checksum, FilesCarryTheirCrc32AsALittleEndianTrailer) {
  test::TempDir dir;
  const std::string path = dir.path() + "/check.bin";
  write_file_with_crc32(path, "123456789");
  const std::string bytes = read_file_bytes(path);
  EXPECT_EQ(bytes, std::string("123456789") + std::string("\x26\x39\xF4\xCB", 4));
  EXPECT_EQ(file_crc32(path), crc32(bytes.data(), bytes.size()));
  EXPECT_THROW(file_crc32(dir.path() + "/missing.bin"), IoError);
}
