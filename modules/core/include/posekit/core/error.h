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

/// An argument or data structure violates a documented precondition.
class InvalidInput : public Error {
 public:
  using Error::Error;
};

}  // namespace posekit
