#pragma once
#include <functional>
#include <ostream>
#include <string>

namespace posekit {

/// Writes a file through `write` into a temporary sibling ("<path>.tmp-<host>-<pid>-<n>", unique per
/// call) and renames it to `path` only when `write` returned, every byte reached the disk (fsync) and
/// the file closed without error; the folder is synced after the rename. A failure leaves nothing
/// behind. `binary` is kept for callers' clarity (the bytes are written as given on POSIX).
/// Throws WriteError (an IoError) naming the file and the system's reason (e.g. "No space left on device").
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write, bool binary = true);

/// True when `name` is a temporary file of write_file_atomically (of any process).
bool is_atomic_temporary_name(const std::string& name);

/// Removes the temporaries write_file_atomically left in `folder` (not recursive) when a process was
/// killed: those of this host whose process no longer runs, and those of other hosts (a shared
/// filesystem) untouched for over a day. Returns how many were removed.
int remove_stale_temporaries(const std::string& folder);

/// Reads a whole file into memory. Throws IoError naming the file when it cannot be read.
std::string read_file_bytes(const std::string& path);

/// Creates `folder` and its missing parents. Throws WriteError naming the folder and the cause (a
/// read-only filesystem, missing permission, a file in the way).
void create_folders(const std::string& folder);

/// Checks that a file can be written at `path`: its folder must exist (unless `make_folder`, which
/// creates it) and be a folder. Throws IoError (WriteError when it cannot be made) naming the folder.
void require_output_folder(const std::string& path, bool make_folder = false);

/// Builds a whole folder through `build`, called with a temporary sibling ("<folder>.tmp-<pid>"),
/// renamed to `folder` when `build` returned; a failure removes the temporary and rethrows. Throws
/// IoError when `folder` exists and `replace` is false, or the temporary cannot be created.
void write_folder_atomically(const std::string& folder, bool replace, const std::function<void(const std::string& temporary)>& build);

}  // namespace posekit
