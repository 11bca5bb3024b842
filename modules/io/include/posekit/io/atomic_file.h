#pragma once
#include <functional>
#include <ostream>
#include <string>

namespace posekit {

/// Writes a file through `write` into a temporary sibling ("<path>.tmp-<pid>") and renames it to
/// `path` only when `write` returned and the stream is good, so a failure leaves nothing behind.
/// `binary` opens the stream in binary mode. Throws IoError naming the file.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                           bool binary = true);

/// Reads a whole file into memory. Throws IoError naming the file when it cannot be read.
std::string read_file_bytes(const std::string& path);

}  // namespace posekit
