#pragma once
/// @file
/// Exception hierarchy. Configuration and model errors throw at setup; the real-time
/// cycle never throws and reports a status instead.

#include <stdexcept>
#include <string>

namespace wbm {

/// Base class of every exception the library throws.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A robot model is inconsistent (bad axis, negative mass, unknown name, loop, ...).
class ModelError : public Error {
 public:
  using Error::Error;
};

/// A model file could not be read or parsed; the message names the file and line.
class ParseError : public ModelError {
 public:
  using ModelError::ModelError;
};

/// A controller, task or solver was configured with invalid parameters.
class ConfigError : public Error {
 public:
  using Error::Error;
};

}  // namespace wbm
