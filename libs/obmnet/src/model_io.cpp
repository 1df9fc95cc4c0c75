#include "obm/obmnet/model_io.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "archive_check.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"

namespace obm::obmnet {

namespace {
constexpr const char* kFormatTag = "obmslam-obmnet-v1";
}

void saveArchiveAtomically(torch::serialize::OutputArchive& archive, const std::string& path,
                           const std::string& what) {
  std::ostringstream bytes(std::ios::out | std::ios::binary);
  try {
    archive.save_to(bytes);
  } catch (const c10::Error& e) {
    throw IoError(path + ": cannot serialise " + what + " (" + e.what_without_backtrace() + ")");
  }
  const std::string data = bytes.str();
  writeFileAtomically(
      path, [&](std::ostream& os) { os.write(data.data(), static_cast<std::streamsize>(data.size())); },
      /*binary=*/true);
}

void saveModel(const std::string& path, ObmNet& model, const ModelMeta& meta) {
  torch::serialize::OutputArchive archive;
  archive.write("format", c10::IValue(std::string(kFormatTag)));
  archive.write("config_yaml", c10::IValue(model->config().toYaml()));
  archive.write("normalize_radius", c10::IValue(meta.normalize_radius));
  archive.write("num_points", c10::IValue(static_cast<int64_t>(meta.num_points)));
  archive.write("description", c10::IValue(meta.description));
  model->save(archive);
  saveArchiveAtomically(archive, path, "the model");
}

ObmNet loadModel(const std::string& path, ModelMeta* meta) {
  if (!std::filesystem::is_regular_file(path)) throw IoError(path + ": model file not found");
  // Every entry against its CRC-32 first: LibTorch does not check them (a damaged weight would
  // load as a wrong number) and its TorchScript parser is not hardened against damaged code.
  detail::verifyZipArchive(path);
  torch::serialize::InputArchive archive;
  try {
    archive.load_from(path);
  } catch (const c10::Error& e) {
    throw FormatError(
        path, 0,
        std::string("not a readable LibTorch archive (") + e.what_without_backtrace() + ")");
  } catch (const std::exception& e) {
    // A damaged TorchScript section of the archive: LibTorch's parser reports it with its own
    // exception types (torch::jit::ErrorReport), not c10::Error.
    throw FormatError(path, 0, std::string("not a readable LibTorch archive (") + e.what() + ")");
  }
  auto readString = [&](const char* key) {
    c10::IValue v;
    if (!archive.try_read(key, v) || !v.isString())
      throw FormatError(path, 0,
                        std::string("not an obmslam model: entry '") + key + "' is missing");
    return v.toStringRef();
  };
  const std::string tag = readString("format");
  if (tag != kFormatTag)
    throw FormatError(path, 0, "model format '" + tag + "' is not '" + kFormatTag + "'");
  ObmNetConfig cfg;
  try {
    cfg = ObmNetConfig::load(ConfigNode::fromString(readString("config_yaml"), path + " (config)"));
  } catch (const ConfigError& e) {
    throw FormatError(path, 0, std::string("bad embedded configuration: ") + e.what());
  }
  ModelMeta m;
  c10::IValue v;
  if (archive.try_read("normalize_radius", v) && v.isDouble()) m.normalize_radius = v.toDouble();
  if (archive.try_read("num_points", v) && v.isInt()) m.num_points = static_cast<int>(v.toInt());
  if (archive.try_read("description", v) && v.isString()) m.description = v.toStringRef();
  if (!(m.normalize_radius > 0.0) || !std::isfinite(m.normalize_radius))
    throw FormatError(path, 0, "normalize_radius " + std::to_string(m.normalize_radius) +
                                   " is not a positive number");
  if (m.num_points < 1)
    throw FormatError(path, 0, "num_points " + std::to_string(m.num_points) + " is not >= 1");
  ObmNet model(cfg);
  try {
    model->load(archive);
  } catch (const c10::Error& e) {
    throw FormatError(path, 0,
                      std::string("weights do not match the embedded configuration (") +
                          e.what_without_backtrace() + ")");
  } catch (const std::exception& e) {
    throw FormatError(path, 0,
                      std::string("weights do not match the embedded configuration (") +
                          e.what() + ")");
  }
  model->eval();
  if (meta) *meta = m;
  return model;
}

}  // namespace obm::obmnet
