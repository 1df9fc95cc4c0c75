#pragma once
/// \file csv.hpp
/// Writing CSV fields that may hold the separator (RFC 4180): free text such as a rejection
/// reason or a pair name ("seq:757->0 (loop, yaw 28°)") goes between double quotes.
#include <string>

namespace obm {

/// The text of a double-quoted CSV field: quotes doubled (write it as '"' + csvQuoted(s) + '"').
inline std::string csvQuoted(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out;
}

}  // namespace obm
