#pragma once
/// \file errors.hpp
/// Exception types. Bad input, bad config and contract violations throw one of these with the
/// file / line / key / frame that is wrong; expected algorithmic failures return a status instead.
#include <stdexcept>
#include <string>

namespace obm {

/// Base of every exception thrown by obmslam.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A file cannot be opened, read or written.
class IoError : public Error {
 public:
  using Error::Error;
};

/// A file opened fine but its content is malformed. The message names the file and, when known,
/// the line (1-based) and what was expected.
class FormatError : public Error {
 public:
  FormatError(const std::string& file, std::size_t line, const std::string& what)
      : Error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + what),
        file_(file),
        line_(line) {}
  const std::string& file() const noexcept { return file_; }
  std::size_t line() const noexcept { return line_; }

 private:
  std::string file_;
  std::size_t line_;
};

/// A configuration key is missing, has the wrong type or an invalid value.
class ConfigError : public Error {
 public:
  using Error::Error;
};

/// A function was called in a way its contract forbids (e.g. mismatched sizes).
class ContractError : public Error {
 public:
  using Error::Error;
};

}  // namespace obm

/// Throw obm::ContractError with file:line and a message when `cond` is false.
#define OBM_ASSERT(cond, msg)                                                                  \
  do {                                                                                         \
    if (!(cond))                                                                               \
      throw ::obm::ContractError(std::string(__FILE__) + ":" + std::to_string(__LINE__) +      \
                                 ": assertion '" #cond "' failed: " + std::string(msg));       \
  } while (0)
