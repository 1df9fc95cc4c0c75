#include "ply_codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "obm/core/errors.hpp"
#include "text_parse.hpp"

namespace obm::io::detail {

std::size_t plyTypeSize(PlyType t) {
  switch (t) {
    case PlyType::Int8:
    case PlyType::UInt8:
      return 1;
    case PlyType::Int16:
    case PlyType::UInt16:
      return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32:
      return 4;
    case PlyType::Float64:
      return 8;
  }
  return 0;
}

const char* plyTypeName(PlyType t) {
  switch (t) {
    case PlyType::Int8:
      return "char";
    case PlyType::UInt8:
      return "uchar";
    case PlyType::Int16:
      return "short";
    case PlyType::UInt16:
      return "ushort";
    case PlyType::Int32:
      return "int";
    case PlyType::UInt32:
      return "uint";
    case PlyType::Float32:
      return "float";
    case PlyType::Float64:
      return "double";
  }
  return "?";
}

namespace {

bool typeFromName(std::string_view s, PlyType& t) {
  // Both the original names and the sized names of later writers (e.g. "float32", "uint8").
  static const struct {
    const char* name;
    PlyType type;
  } kTypes[] = {
      {"char", PlyType::Int8},      {"int8", PlyType::Int8},       {"uchar", PlyType::UInt8},
      {"uint8", PlyType::UInt8},    {"short", PlyType::Int16},     {"int16", PlyType::Int16},
      {"ushort", PlyType::UInt16},  {"uint16", PlyType::UInt16},   {"int", PlyType::Int32},
      {"int32", PlyType::Int32},    {"uint", PlyType::UInt32},     {"uint32", PlyType::UInt32},
      {"float", PlyType::Float32},  {"float32", PlyType::Float32}, {"double", PlyType::Float64},
      {"float64", PlyType::Float64}};
  const std::string low = toLower(s);
  for (const auto& k : kTypes)
    if (low == k.name) {
      t = k.type;
      return true;
    }
  return false;
}

bool isIntegerType(PlyType t) {
  return t != PlyType::Float32 && t != PlyType::Float64;
}

}  // namespace

int PlyElement::find(std::string_view n) const {
  const std::string low = toLower(n);
  for (std::size_t i = 0; i < properties.size(); ++i)
    if (toLower(properties[i].name) == low) return static_cast<int>(i);
  return -1;
}

PlyHeader parsePlyHeader(const std::string& file, std::string_view data) {
  PlyHeader h;
  LineCursor cur(data);
  std::string_view line;
  std::vector<std::string_view> tok;
  if (!cur.next(line) || trim(line) != "ply")
    throw FormatError(file, 1, "not a PLY file: the first line must be 'ply'");
  bool have_format = false;
  while (true) {
    if (!cur.next(line))
      throw FormatError(file, cur.lineNumber(), "PLY header has no 'end_header' line");
    const std::size_t ln = cur.lineNumber();
    splitBlanks(line, tok);
    if (tok.empty()) continue;
    const std::string_view kw = tok[0];
    if (kw == "comment") {
      const std::string_view rest = trim(line);
      h.comments.emplace_back(trim(rest.substr(std::min<std::size_t>(7, rest.size()))));
      continue;
    }
    if (kw == "obj_info") continue;
    if (kw == "end_header") {
      if (!have_format) throw FormatError(file, ln, "PLY header has no 'format' line");
      // The body starts after the '\n' that ends this line (the spec's line ending; a header
      // written with "\r\n" also ends in '\n').
      const std::size_t nl = data.find('\n', static_cast<std::size_t>(line.data() - data.data()));
      h.body_offset = nl == std::string_view::npos ? data.size() : nl + 1;
      h.body_first_line = ln + 1;
      // The counts must fit in the body (at least one byte per binary value, two characters per
      // ascii value) before anyone allocates for them: a corrupt count fails here, cleanly.
      const double body = static_cast<double>(data.size() - h.body_offset);
      double need = 0.0;
      for (const auto& e : h.elements) {
        double per = 0.0;
        for (const auto& p : e.properties)
          per += h.encoding == PlyEncoding::Ascii
                     ? 2.0
                     : static_cast<double>(plyTypeSize(p.is_list ? p.count_type : p.type));
        need += per * static_cast<double>(e.count);
      }
      if (h.encoding == PlyEncoding::Ascii) need -= 1.0;  // the last value may end the file
      if (need > body)
        throw FormatError(file, ln,
                          "the header declares more data than the file holds (" +
                              std::to_string(static_cast<unsigned long long>(body)) +
                              " bytes after the header): truncated file or corrupt counts");
      return h;
    }
    if (kw == "format") {
      if (tok.size() != 3) throw FormatError(file, ln, "expected 'format <encoding> 1.0'");
      if (tok[1] == "ascii")
        h.encoding = PlyEncoding::Ascii;
      else if (tok[1] == "binary_little_endian")
        h.encoding = PlyEncoding::BinaryLittleEndian;
      else if (tok[1] == "binary_big_endian")
        h.encoding = PlyEncoding::BinaryBigEndian;
      else
        throw FormatError(file, ln, "unknown PLY encoding '" + std::string(tok[1]) + "'");
      have_format = true;
    } else if (kw == "element") {
      long long n = -1;
      if (tok.size() != 3 || !parseNumber(tok[2], n) || n < 0)
        throw FormatError(file, ln, "expected 'element <name> <count>'");
      PlyElement e;
      e.name = std::string(tok[1]);
      e.count = static_cast<std::size_t>(n);
      e.header_line = ln;
      h.elements.push_back(std::move(e));
    } else if (kw == "property") {
      if (h.elements.empty()) throw FormatError(file, ln, "'property' before any 'element' line");
      PlyProperty p;
      if (tok.size() == 5 && tok[1] == "list") {
        p.is_list = true;
        if (!typeFromName(tok[2], p.count_type) || !isIntegerType(p.count_type))
          throw FormatError(file, ln, "bad list count type '" + std::string(tok[2]) + "'");
        if (!typeFromName(tok[3], p.type))
          throw FormatError(file, ln, "unknown property type '" + std::string(tok[3]) + "'");
        p.name = std::string(tok[4]);
      } else if (tok.size() == 3) {
        if (!typeFromName(tok[1], p.type))
          throw FormatError(file, ln, "unknown property type '" + std::string(tok[1]) + "'");
        p.name = std::string(tok[2]);
      } else {
        throw FormatError(file, ln,
                          "expected 'property <type> <name>' or 'property list <count-type> "
                          "<item-type> <name>'");
      }
      h.elements.back().properties.push_back(std::move(p));
    } else {
      throw FormatError(file, ln, "unknown PLY header keyword '" + std::string(kw) + "'");
    }
  }
}

PlyBodyReader::PlyBodyReader(const std::string& file, std::string_view data,
                             const PlyHeader& header)
    : file_(file),
      data_(data),
      pos_(header.body_offset),
      line_(header.body_first_line),
      binary_(header.encoding != PlyEncoding::Ascii),
      swap_(binary_ &&
            ((header.encoding == PlyEncoding::BinaryBigEndian) == hostIsLittleEndian())) {}

std::string_view PlyBodyReader::nextToken(const PlyElement& el, std::size_t index) {
  while (pos_ < data_.size()) {
    const char c = data_[pos_];
    if (c == '\n') {
      ++line_;
    } else if (c != ' ' && c != '\t' && c != '\r' && c != '\f' && c != '\v') {
      break;
    }
    ++pos_;
  }
  if (pos_ >= data_.size())
    throw FormatError(file_, line_,
                      "PLY body ends early: element '" + el.name + "' has " +
                          std::to_string(el.count) + " records but record " +
                          std::to_string(index) + " is incomplete");
  const std::size_t b = pos_;
  while (pos_ < data_.size()) {
    const char c = data_[pos_];
    if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v') break;
    ++pos_;
  }
  return data_.substr(b, pos_ - b);
}

double PlyBodyReader::readValue(PlyType t, const PlyElement& el, std::size_t index) {
  if (!binary_) {
    const std::string_view tok = nextToken(el, index);
    double v = 0.0;
    if (!parseNumber(tok, v))
      throw FormatError(file_, line_,
                        "element '" + el.name + "' record " + std::to_string(index) + ": '" +
                            std::string(tok) + "' is not a number");
    return v;
  }
  const std::size_t n = plyTypeSize(t);
  if (pos_ + n > data_.size())
    throw FormatError(file_, 0,
                      "binary PLY body is truncated: element '" + el.name + "' has " +
                          std::to_string(el.count) + " records but the file ends in record " +
                          std::to_string(index));
  unsigned char b[8];
  std::memcpy(b, data_.data() + pos_, n);
  pos_ += n;
  if (swap_) std::reverse(b, b + n);
  switch (t) {
    case PlyType::Int8: {
      std::int8_t v;
      std::memcpy(&v, b, 1);
      return v;
    }
    case PlyType::UInt8:
      return b[0];
    case PlyType::Int16: {
      std::int16_t v;
      std::memcpy(&v, b, 2);
      return v;
    }
    case PlyType::UInt16: {
      std::uint16_t v;
      std::memcpy(&v, b, 2);
      return v;
    }
    case PlyType::Int32: {
      std::int32_t v;
      std::memcpy(&v, b, 4);
      return v;
    }
    case PlyType::UInt32: {
      std::uint32_t v;
      std::memcpy(&v, b, 4);
      return v;
    }
    case PlyType::Float32: {
      float v;
      std::memcpy(&v, b, 4);
      return v;
    }
    case PlyType::Float64: {
      double v;
      std::memcpy(&v, b, 8);
      return v;
    }
  }
  return 0.0;
}

void PlyBodyReader::read(const PlyElement& el, std::size_t index, std::vector<double>& values,
                         std::vector<std::vector<double>>& lists) {
  const std::size_t np = el.properties.size();
  values.resize(np);
  lists.resize(np);
  for (std::size_t p = 0; p < np; ++p) {
    const PlyProperty& prop = el.properties[p];
    if (!prop.is_list) {
      values[p] = readValue(prop.type, el, index);
      continue;
    }
    values[p] = std::numeric_limits<double>::quiet_NaN();
    const double n = readValue(prop.count_type, el, index);
    if (!(n >= 0) || n != std::floor(n) || n > 1e6)
      throw FormatError(file_, line(),
                        "element '" + el.name + "' record " + std::to_string(index) +
                            ": bad list length for '" + prop.name + "'");
    auto& items = lists[p];
    items.resize(static_cast<std::size_t>(n));
    for (auto& it : items) it = readValue(prop.type, el, index);
  }
}

void PlyBodyReader::skip(const PlyElement& el) {
  // A record without properties holds no bytes: nothing to skip, however large the count (a
  // header saying "element x 10000000000" with no property would otherwise loop for hours).
  if (el.properties.empty()) return;
  std::vector<double> v;
  std::vector<std::vector<double>> l;
  for (std::size_t i = 0; i < el.count; ++i) read(el, i, v, l);
}

void writePlyBinary(std::ostream& os, PlyType t, double v, bool big_endian) {
  unsigned char b[8];
  const std::size_t n = plyTypeSize(t);
  switch (t) {
    case PlyType::Int8: {
      const auto x = static_cast<std::int8_t>(v);
      std::memcpy(b, &x, 1);
    } break;
    case PlyType::UInt8: {
      const auto x = static_cast<std::uint8_t>(v);
      std::memcpy(b, &x, 1);
    } break;
    case PlyType::Int16: {
      const auto x = static_cast<std::int16_t>(v);
      std::memcpy(b, &x, 2);
    } break;
    case PlyType::UInt16: {
      const auto x = static_cast<std::uint16_t>(v);
      std::memcpy(b, &x, 2);
    } break;
    case PlyType::Int32: {
      const auto x = static_cast<std::int32_t>(v);
      std::memcpy(b, &x, 4);
    } break;
    case PlyType::UInt32: {
      const auto x = static_cast<std::uint32_t>(v);
      std::memcpy(b, &x, 4);
    } break;
    case PlyType::Float32: {
      const auto x = static_cast<float>(v);
      std::memcpy(b, &x, 4);
    } break;
    case PlyType::Float64:
      std::memcpy(b, &v, 8);
      break;
  }
  if (big_endian == hostIsLittleEndian()) std::reverse(b, b + n);
  os.write(reinterpret_cast<const char*>(b), static_cast<std::streamsize>(n));
}

}  // namespace obm::io::detail
