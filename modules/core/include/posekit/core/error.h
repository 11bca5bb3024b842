#pragma once
// Error hierarchy of posekit. Every message names the file/element and what was expected.
#include <stdexcept>
#include <string>

namespace posekit {

/// Base of every error posekit throws.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A file could not be read or written, or its content is not what its format requires.
class IoError : public Error {
 public:
  using Error::Error;
};

/// A file or folder could not be written (no space left, a read-only filesystem, no permission):
/// the message names the path and the system's reason. Work that writes many files stops at the first.
class WriteError : public IoError {
 public:
  using IoError::IoError;
};

/// An argument or data structure violates a documented precondition.
class InvalidInput : public Error {
 public:
  using Error::Error;
};

/// A result was computed but its own checks say it is probably wrong (a poor body fit: little of the
/// body on the target, much of the target off the body, an implausible shape): the command writes
/// nothing unless told to accept it, and exits with status 3.
class BelowConfidence : public Error {
 public:
  using Error::Error;
};

}  // namespace posekit
