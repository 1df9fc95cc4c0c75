#pragma once
/// \file model_io.hpp
/// The trained-model file: one LibTorch archive holding the model's hyper-parameters (YAML text),
/// the normalisation radius of its training data, a format tag, and every parameter and buffer.
/// The inference API loads it without the training code.
#include <string>

#include "obm/obmnet/model.hpp"

namespace obm::obmnet {

/// What travels with the weights.
struct ModelMeta {
  double normalize_radius = 1.0;  ///< radius the pairs were scaled to in training
  int num_points = 1024;          ///< points per cloud the model was trained with
  std::string description;        ///< free text (protocol, data) shown by tools
};

/// Serialises `archive` in memory, then writes the bytes atomically to `path` (temporary file +
/// rename). LibTorch's own file writer throws from a destructor when the disk fills up, which
/// ends the process; here a full disk is an IoError naming `path` and the system's reason, and
/// no half-written file is left. `what` names the file's role in the error ("the model").
void saveArchiveAtomically(torch::serialize::OutputArchive& archive, const std::string& path,
                           const std::string& what);

/// Writes the model atomically (temporary file + rename). Throws IoError naming `path`.
void saveModel(const std::string& path, ObmNet& model, const ModelMeta& meta);

/// Loads a model written by saveModel, in eval mode. A missing, corrupt or mismatched file throws
/// obm::IoError / obm::FormatError naming `path` and what is wrong.
ObmNet loadModel(const std::string& path, ModelMeta* meta = nullptr);

}  // namespace obm::obmnet
