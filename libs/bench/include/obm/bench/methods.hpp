#pragma once
/// \file methods.hpp
/// The rows obm-bench scores, each built from a preset's matcher (docs/obm-bench.md, "Rows"):
/// the network alone and with ICP, ICP alone, the correlative search, the module as a plug-in and
/// the Open3D peers. Row names are parsed once into `Row`; every row of one run shares the
/// preset's settings, so rows differ only in what their name says.
#include <string>
#include <vector>

#include "obm/bench/peers.hpp"
#include "obm/bench/preset.hpp"

namespace obm::bench {

/// Every row the registry builds (names in rowName; the Open3D peers are listed by peers.hpp).
enum class Row {
  Obmnet,                   ///< "obmnet": the network alone (its registrar), from the identity
  ObmnetVerify,             ///< "obmnet+verify": ... its start kept when fitter than its poses
  ObmnetTeacher,            ///< "obmnet+teacher": ... refined as the self-training teacher does
  ObmnetRansac,             ///< "obmnet+ransac": RANSAC on its matches, hypotheses by fitness
  ObmnetConsensus,          ///< "obmnet+consensus": ... hypotheses by RANSAC consensus
  ObmnetAtTruth,            ///< "obmnet@truth": the network started at the answer (diagnostic)
  Identity,                 ///< "identity": not moving (the pair as given)
  ObmnetIcp,                ///< "obmnet+icp": the preset's matcher without the search
  ObmnetIcpAll,             ///< "obmnet+icp-all": every yaw hypothesis refined
  ObmnetIcpAllYaw4,         ///< "obmnet+icp-all+yaw4": ... and ICP from four blind headings
  ObmnetRansacIcp,          ///< "obmnet+ransac+icp"
  ObmnetRansacIcpAllYaw4,   ///< "obmnet+ransac+icp-all+yaw4"
  ObmnetConsensusIcp,       ///< "obmnet+consensus+icp"
  ObmnetConsensusIcpAllYaw4,///< "obmnet+consensus+icp-all+yaw4"
  ObmnetIcpSearch,          ///< "obmnet+icp+search": the preset's matcher with the search's poses
  ObmnetIcpOrIcp,           ///< "obmnet+icp|icp": both starts, the one pairing more points kept
  ObmnetIcpTurns,           ///< "obmnet+icp-turns": more starts (benchmark.start_turn_deg)
  Icp,                      ///< "icp": ICP from the identity, the wide start gate
  IcpAtTruth,               ///< "icp@truth": the refinement started at the answer (ceiling)
  IcpYaw4,                  ///< "icp-yaw4": ICP from four headings about z
  IcpTurns,                 ///< "icp-turns": ICP from the start turns
  Search,                   ///< "search": the correlative search's best pose
  SearchIcp,                ///< "search+icp": the refinement from each of the search's poses
  ObmmIcp,                  ///< "obmm+icp": ICP weighted by the module's ω
  ObmmFgr,                  ///< "obmm+fgr": FGR on the points the module puts in the overlap
  ObmmRansac,               ///< "obmm+ransac": RANSAC + FPFH on them
  ObmnetIcpTurnsFgr,        ///< "obmnet+icp-turns+fgr": FGR's pose as one more start
  ObmnetIcpAtFgr,           ///< "obmnet+icp@fgr": the network + ICP from FGR's pose
  ObmnetIcpTurnsFgrSearch,  ///< "obmnet+icp-turns+fgr+search"
  O3dFgrObmIcp,             ///< "o3d_fgr+obm_icp": FGR, then the project's refinement
  Open3d,                   ///< one of the Open3D peers (peers.hpp), by its own name
};

/// A row as named on the command line.
struct RowRequest {
  Row row = Row::Obmnet;
  std::string name;  ///< the name given (an Open3D peer's own name)
};

/// Parses one row name; throws ConfigError "`where`: unknown method 'x' (...)" listing the names.
/// "open3d" is not a row (see expandRows).
RowRequest parseRow(const std::string& name, const std::string& where);
/// The row's name ("obmnet+icp", ...; Open3d rows keep their peer's name).
std::string rowName(Row row);

/// `names` parsed in order; "open3d" expands to every Open3D peer of this build (those of
/// `open3d` with colours when `coloured`).
std::vector<RowRequest> expandRows(const std::vector<std::string>& names, const std::string& where,
                                   bool coloured);

/// What a run adds to the preset: per-run choices that are not the matcher's.
struct RunOptions {
  std::uint64_t seed = 1;       ///< the search's scored subset
  bool coloured = false;        ///< every pair's clouds carry colours (Open3D's coloured rows)
  std::string teacher_config;   ///< YAML with train.teacher (the obmnet+teacher row)
};

/// The rows `rows` of `preset`, in order, each sharing one matcher per configuration (one model
/// load). Throws ConfigError naming the row when it needs what the preset or the build lacks
/// (start turns, an OBMNet model, Open3D).
std::vector<Method> buildMethods(const Preset& preset, const std::vector<RowRequest>& rows,
                                 const RunOptions& run);

/// One `obmnet` row per model file (the ablation table: OS / BP / NMM variants).
std::vector<Method> ablationMethods(const Preset& preset, const std::vector<std::string>& models);

}  // namespace obm::bench
