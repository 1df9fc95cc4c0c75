// YAML loading of the matcher parameters and the factory; the shipped config files load.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/registration/factory.hpp"
#include "test_data.hpp"

namespace obm {
namespace {

TEST(RegistrationConfig, LoadsEveryKey) {
  const auto node = ConfigNode::fromString(R"(
type: icp
icp:
  source_voxel: 0.3
  target_voxel: 0.2
  normal_neighbors: 12
  min_planarity: 0.2
  max_correspondence_distance: 0.8
  initial_max_correspondence_distance: 3.0
  anneal_factor: 0.4
  metric: point_to_point
  point_to_point_fallback: false
  kernel: tukey
  kernel_scale: 0.25
  solver: gauss_newton
  max_iterations: 17
  translation_tolerance: 1.0e-5
  rotation_tolerance_deg: 0.01
  min_correspondences: 40
  threads: 1
confidence:
  inlier_threshold: 0.3
  min_sigma: 0.01
  information_scale: 0.5
  inlier_ratio_ref: 0.6
  overlap_ref: 0.4
  conditioning_ref: 0.03
  degeneracy_threshold: 0.002
  color_inlier_threshold: 0.07
)");
  const registration::ScanMatcherConfig c = registration::ScanMatcherConfig::load(node);
  EXPECT_EQ(c.type, registration::MatcherKind::Icp);
  EXPECT_EQ(c.icp.source_voxel, 0.3);
  EXPECT_EQ(c.icp.target_voxel, 0.2);
  EXPECT_EQ(c.icp.normal_neighbors, 12);
  EXPECT_EQ(c.icp.min_planarity, 0.2);
  EXPECT_EQ(c.icp.max_correspondence_distance, 0.8);
  EXPECT_EQ(c.icp.initial_max_correspondence_distance, 3.0);
  EXPECT_EQ(c.icp.anneal_factor, 0.4);
  EXPECT_EQ(c.icp.metric, registration::IcpMetric::PointToPoint);
  EXPECT_FALSE(c.icp.point_to_point_fallback);
  EXPECT_EQ(c.icp.kernel, registration::RobustKernel::Tukey);
  EXPECT_EQ(c.icp.kernel_scale, 0.25);
  EXPECT_EQ(c.icp.solver, registration::IcpSolver::GaussNewton);
  EXPECT_EQ(c.icp.max_iterations, 17);
  EXPECT_EQ(c.icp.translation_tolerance, 1e-5);
  EXPECT_DOUBLE_EQ(c.icp.rotation_tolerance, 0.01 * kDegToRad);
  EXPECT_EQ(c.icp.min_correspondences, 40);
  EXPECT_EQ(c.icp.threads, 1);
  EXPECT_EQ(c.confidence.inlier_threshold, 0.3);
  EXPECT_EQ(c.confidence.min_sigma, 0.01);
  EXPECT_EQ(c.confidence.information_scale, 0.5);
  EXPECT_EQ(c.confidence.inlier_ratio_ref, 0.6);
  EXPECT_EQ(c.confidence.overlap_ref, 0.4);
  EXPECT_EQ(c.confidence.conditioning_ref, 0.03);
  EXPECT_EQ(c.confidence.degeneracy_threshold, 0.002);
  EXPECT_EQ(c.confidence.color_inlier_threshold, 0.07);
  const auto m = registration::makeScanMatcher(c);
  EXPECT_EQ(m->name(), "icp");
  EXPECT_EQ(m->icpParams().kernel, registration::RobustKernel::Tukey);
  const registration::PreparedTarget::Options o = c.icp.targetOptions();
  EXPECT_EQ(o.voxel, 0.2);
  EXPECT_EQ(o.normal_neighbors, 12);
}

TEST(RegistrationConfig, DefaultsWhenKeysAreAbsent) {
  const registration::ScanMatcherConfig c =
      registration::ScanMatcherConfig::load(ConfigNode::fromString("{}"));
  EXPECT_EQ(c.type, registration::MatcherKind::Icp);
  EXPECT_EQ(c.icp.max_correspondence_distance,
            registration::IcpParams().max_correspondence_distance);
  EXPECT_EQ(c.icp.kernel, registration::IcpParams().kernel);
  EXPECT_EQ(c.confidence.min_sigma, registration::ConfidenceParams().min_sigma);
}

void expectConfigError(const std::string& yaml, const std::string& fragment) {
  try {
    registration::ScanMatcherConfig::load(ConfigNode::fromString(yaml, "test.yaml"));
    FAIL() << "no ConfigError for: " << yaml;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("test.yaml"), std::string::npos) << e.what();
  }
}

TEST(RegistrationConfig, ErrorsNameFileAndKey) {
  expectConfigError("type: ndt", "type");
  expectConfigError("typo: icp", "typo");
  expectConfigError("icp: {kernel: welsch}", "icp.kernel");
  expectConfigError("icp: {metric: plane}", "icp.metric");
  expectConfigError("icp: {solver: newton}", "icp.solver");
  expectConfigError("icp: {max_correspondence_distance: -1}", "max_correspondence_distance");
  expectConfigError("icp: {final_kernel_scale: -0.01}", "final_kernel_scale");
  expectConfigError("icp: {weak_direction_threshold: 1.5}", "weak_direction_threshold");
  expectConfigError("icp: {max_iterations: many}", "icp.max_iterations");
  expectConfigError("icp: {kernel_sclae: 1}", "icp.kernel_sclae");
  expectConfigError("confidence: {min_sigma: 0}", "min_sigma");
  expectConfigError("type: obmnet", "obmnet");
  expectConfigError("type: obmnet+icp\nobmnet: {threads: 2}", "obmnet.model_path");
  expectConfigError("type: obmnet\nobmnet: {model_path: m.pt, pre_aling: true}",
                    "obmnet.pre_aling");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, overlap_stage_keep: 1.5}",
                    "obmnet.overlap_stage_keep");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, overlap_stage_gate_factor: 0.5}",
                    "obmnet.overlap_stage_gate_factor");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, refine_hypotheses: -1}",
                    "obmnet.refine_hypotheses");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, init_headings: -2}",
                    "obmnet.init_headings");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, init_headings_gate: -1}",
                    "obmnet.init_headings_gate");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, init_headings_margin: 0.9}",
                    "obmnet.init_headings_margin");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, iterations: -1}",
                    "obmnet.iterations");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, ransac_iterations: -5}",
                    "obmnet.ransac_iterations");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, spatial_sigma: -0.5}",
                    "obmnet.spatial_sigma");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, start_turn_deg: -5}",
                    "obmnet.start_turn_deg");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, start_turn_axes: xw}",
                    "obmnet.start_turn_axes");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, start_turn_axes: xx}",
                    "obmnet.start_turn_axes");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, search_candidates: -1}",
                    "obmnet.search_candidates");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, search: {axis: w}}",
                    "obmnet.search");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, search: {cells: 1}}", "cells");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, choice_plane_distance: -1}",
                    "obmnet.choice_plane_distance");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, choice_free_space_weight: -1}",
                    "obmnet.choice_free_space_weight");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, choice_inlier_power: -1}",
                    "obmnet.choice_inlier_power");
  expectConfigError(
      "type: obmnet+icp\nobmnet: {model_path: m.pt, hypothesis_free_space_weight: -1}",
      "obmnet.hypothesis_free_space_weight");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, free_space: {margin: -1}}",
                    "obmnet.free_space");
  expectConfigError(
      "type: obmnet+icp\nobmnet: {model_path: m.pt, free_space: {azimuth_step_deg: 0}}",
      "obmnet.free_space");
  // Every rotation on a grid too fine to search.
  expectConfigError(
      "type: obmnet+icp\nobmnet: {model_path: m.pt, search: {axis: any, heading_step_deg: 1}}",
      "obmnet.search");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, ransac_candidates: 5}",
                    "obmnet.ransac_candidates");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, ransac_inlier_spacing: 0}",
                    "obmnet.ransac_inlier_spacing");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, ransac_max_turn_deg: 200}",
                    "obmnet.ransac_max_turn_deg");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, start_heading_margin: 0.5}",
                    "obmnet.start_heading_margin");
  expectConfigError("type: obmnet+icp\nobmnet: {model_path: m.pt, free_space: {sensor: radar}}",
                    "obmnet.free_space.sensor");
}

TEST(RegistrationConfig, ObmNetKeysAndRelativeModelPath) {
  const registration::ScanMatcherConfig c = registration::ScanMatcherConfig::load(
      ConfigNode::loadFile(obm::test::sourceDir() + "/config/registration/obmnet_icp.yaml"));
  EXPECT_EQ(c.type, registration::MatcherKind::ObmNetIcp);
  EXPECT_TRUE(c.obmnet.pre_align);
  // Resolved against the YAML file's folder.
  EXPECT_EQ(c.obmnet.network.model_path.rfind(obm::test::sourceDir() + "/config/registration/", 0), 0u)
      << c.obmnet.network.model_path;
  const auto s = registration::ScanMatcherConfig::load(ConfigNode::fromString(
      "type: obmnet\nobmnet: {model_path: /abs/m.pt, num_points: 512, threads: 1, seed: 7, "
      "pre_align: false, keep_init_if_better: false, overlap_stage_keep: 0.3, "
      "overlap_stage_gate_factor: 3, refine_hypotheses: 0, init_headings: 8, "
      "init_headings_gate: 5, init_headings_margin: 1.2, iterations: 4, ransac_iterations: 3000, "
      "ransac_candidates: 2, ransac_inlier_spacing: 1.5, ransac_max_turn_deg: 30, "
      "select_by_consensus: false, start_heading_margin: 1.25, spatial_sigma: 0.05, start_turn_deg: 25, start_turn_axes: zx, "
      "search_candidates: 3, search: {axis: y, heading_range_deg: 90, translation_range: 2, "
      "cell: 0.2, align_centroids: true}, choice_plane_distance: 0.02, choice_inlier_power: 2, "
      "choice_free_space_weight: 8, hypothesis_free_space_weight: 3, "
      "free_space: {sensor: camera, azimuth_step_deg: 3, elevation_step_deg: 1.5, relative_margin: 0.2, "
      "min_range: 2}}"));
  EXPECT_EQ(s.obmnet.search_candidates, 3);
  EXPECT_EQ(s.obmnet.search.axis, "y");
  EXPECT_DOUBLE_EQ(s.obmnet.search.heading_range_deg, 90.0);
  EXPECT_DOUBLE_EQ(s.obmnet.search.translation_range, 2.0);
  EXPECT_DOUBLE_EQ(s.obmnet.search.cell, 0.2);
  EXPECT_TRUE(s.obmnet.search.align_centroids);
  EXPECT_DOUBLE_EQ(s.obmnet.choice_plane_distance, 0.02);
  EXPECT_DOUBLE_EQ(c.obmnet.choice_plane_distance, 0.0);  // the shipped YAML: off
  EXPECT_DOUBLE_EQ(s.obmnet.choice_inlier_power, 2.0);
  EXPECT_DOUBLE_EQ(c.obmnet.choice_inlier_power, 0.0);  // the shipped YAML: off
  EXPECT_DOUBLE_EQ(s.obmnet.choice_free_space_weight, 8.0);
  EXPECT_DOUBLE_EQ(s.obmnet.hypothesis_free_space_weight, 3.0);
  EXPECT_DOUBLE_EQ(c.obmnet.hypothesis_free_space_weight, 0.0);
  EXPECT_DOUBLE_EQ(s.obmnet.free_space.azimuth_step_deg, 3.0);
  EXPECT_DOUBLE_EQ(s.obmnet.free_space.elevation_step_deg, 1.5);
  EXPECT_DOUBLE_EQ(s.obmnet.free_space.relative_margin, 0.2);
  EXPECT_DOUBLE_EQ(s.obmnet.free_space.min_range, 2.0);
  EXPECT_EQ(s.obmnet.free_space.sensor, registration::FreeSpaceSensor::Camera);
  EXPECT_DOUBLE_EQ(s.obmnet.network.start_heading_margin, 1.25);
  // The shipped YAML: off, and the defaults its comments give.
  const registration::FreeSpaceParams f;
  EXPECT_DOUBLE_EQ(c.obmnet.choice_free_space_weight, 0.0);
  EXPECT_DOUBLE_EQ(c.obmnet.free_space.azimuth_step_deg, f.azimuth_step_deg);
  EXPECT_DOUBLE_EQ(c.obmnet.free_space.elevation_step_deg, f.elevation_step_deg);
  EXPECT_DOUBLE_EQ(c.obmnet.free_space.margin, f.margin);
  EXPECT_DOUBLE_EQ(c.obmnet.free_space.relative_margin, f.relative_margin);
  EXPECT_DOUBLE_EQ(c.obmnet.free_space.min_range, f.min_range);
  EXPECT_EQ(c.obmnet.free_space.sensor, registration::FreeSpaceSensor::Lidar);
  EXPECT_DOUBLE_EQ(c.obmnet.network.start_heading_margin, 1.0);
  EXPECT_EQ(c.obmnet.search_candidates, 0);  // the shipped YAML: no search
  EXPECT_EQ(c.obmnet.search.axis, "z");
  // ... and otherwise the search's defaults, as the YAML's comments say.
  const registration::CorrelativeSearchParams d;
  EXPECT_EQ(c.obmnet.search.axis_from_floor, d.axis_from_floor);
  EXPECT_DOUBLE_EQ(c.obmnet.search.max_tilt_deg, d.max_tilt_deg);
  EXPECT_DOUBLE_EQ(c.obmnet.search.heading_range_deg, d.heading_range_deg);
  EXPECT_DOUBLE_EQ(c.obmnet.search.heading_step_deg, d.heading_step_deg);
  EXPECT_DOUBLE_EQ(c.obmnet.search.translation_range, d.translation_range);
  EXPECT_DOUBLE_EQ(c.obmnet.search.axial_range, d.axial_range);
  EXPECT_EQ(c.obmnet.search.align_centroids, d.align_centroids);
  EXPECT_DOUBLE_EQ(c.obmnet.search.cell, d.cell);
  EXPECT_EQ(c.obmnet.search.sample_points, d.sample_points);
  EXPECT_EQ(c.obmnet.search.shifts_per_heading, d.shifts_per_heading);
  EXPECT_DOUBLE_EQ(c.obmnet.search.min_separation_deg, d.min_separation_deg);
  EXPECT_DOUBLE_EQ(c.obmnet.search.min_separation_m, d.min_separation_m);
  EXPECT_DOUBLE_EQ(c.obmnet.search.color_tolerance, d.color_tolerance);
  EXPECT_EQ(c.obmnet.search.seed, d.seed);
  EXPECT_FALSE(s.obmnet.network.select_by_consensus);
  EXPECT_TRUE(c.obmnet.network.select_by_consensus);
  EXPECT_EQ(s.obmnet.network.iterations, 4);
  EXPECT_DOUBLE_EQ(s.obmnet.network.spatial_sigma, 0.05);
  EXPECT_DOUBLE_EQ(c.obmnet.network.spatial_sigma, -1.0);  // the shipped YAML: the model's own
  EXPECT_DOUBLE_EQ(s.obmnet.start_turn_deg, 25.0);
  EXPECT_EQ(s.obmnet.start_turn_axes, "zx");
  EXPECT_DOUBLE_EQ(c.obmnet.start_turn_deg, 0.0);  // the shipped YAML: one start
  EXPECT_EQ(s.obmnet.network.ransac_iterations, 3000);
  EXPECT_EQ(s.obmnet.network.ransac_candidates, 2);
  EXPECT_DOUBLE_EQ(s.obmnet.network.ransac_inlier_spacing, 1.5);
  EXPECT_DOUBLE_EQ(s.obmnet.network.ransac_max_turn_deg, 30.0);
  EXPECT_EQ(c.obmnet.network.ransac_iterations, 0);  // the shipped YAML: the weighted SVD alone
  EXPECT_DOUBLE_EQ(s.obmnet.init_headings_gate, 5.0);
  EXPECT_DOUBLE_EQ(s.obmnet.init_headings_margin, 1.2);
  EXPECT_EQ(s.obmnet.refine_hypotheses, 0);
  EXPECT_EQ(s.obmnet.init_headings, 8);
  EXPECT_EQ(c.obmnet.refine_hypotheses, 1);  // the fittest hypothesis only, no blind headings
  EXPECT_EQ(c.obmnet.init_headings, 0);
  EXPECT_EQ(s.obmnet.network.model_path, "/abs/m.pt");
  EXPECT_DOUBLE_EQ(s.obmnet.overlap_stage_keep, 0.3);
  EXPECT_DOUBLE_EQ(s.obmnet.overlap_stage_gate_factor, 3.0);
  EXPECT_DOUBLE_EQ(c.obmnet.overlap_stage_keep, 0.0);  // off unless asked for
  EXPECT_EQ(s.obmnet.network.num_points, 512);
  EXPECT_EQ(s.obmnet.network.threads, 1);
  EXPECT_EQ(s.obmnet.network.seed, 7u);
  EXPECT_FALSE(s.obmnet.pre_align);
  EXPECT_FALSE(s.obmnet.keep_init_if_better);
}

TEST(RegistrationConfig, ShippedIcpConfigHoldsTheDefaults) {
  // config/registration/icp.yaml documents every key with its default value.
  const registration::ScanMatcherConfig c = registration::ScanMatcherConfig::load(
      ConfigNode::loadFile(obm::test::sourceDir() + "/config/registration/icp.yaml"));
  const registration::IcpParams d;
  EXPECT_EQ(c.type, registration::MatcherKind::Icp);
  EXPECT_EQ(c.icp.source_voxel, d.source_voxel);
  EXPECT_EQ(c.icp.target_voxel, d.target_voxel);
  EXPECT_EQ(c.icp.normal_neighbors, d.normal_neighbors);
  EXPECT_EQ(c.icp.min_planarity, d.min_planarity);
  EXPECT_EQ(c.icp.max_correspondence_distance, d.max_correspondence_distance);
  EXPECT_EQ(c.icp.initial_max_correspondence_distance, d.initial_max_correspondence_distance);
  EXPECT_EQ(c.icp.anneal_factor, d.anneal_factor);
  EXPECT_EQ(c.icp.metric, d.metric);
  EXPECT_EQ(c.icp.point_to_point_fallback, d.point_to_point_fallback);
  EXPECT_EQ(c.icp.kernel, d.kernel);
  EXPECT_EQ(c.icp.kernel_scale, d.kernel_scale);
  EXPECT_EQ(c.icp.final_kernel_scale, d.final_kernel_scale);
  EXPECT_EQ(c.icp.weak_direction_threshold, d.weak_direction_threshold);
  EXPECT_EQ(c.icp.polish_max_correspondence_distance, d.polish_max_correspondence_distance);
  EXPECT_EQ(c.icp.solver, d.solver);
  EXPECT_EQ(c.icp.max_iterations, d.max_iterations);
  EXPECT_EQ(c.icp.translation_tolerance, d.translation_tolerance);
  EXPECT_NEAR(c.icp.rotation_tolerance, d.rotation_tolerance, 1e-15);
  EXPECT_EQ(c.icp.min_correspondences, d.min_correspondences);
  EXPECT_EQ(c.icp.threads, d.threads);
  const registration::ConfidenceParams cd;
  EXPECT_EQ(c.confidence.inlier_threshold, cd.inlier_threshold);
  EXPECT_EQ(c.confidence.min_sigma, cd.min_sigma);
  EXPECT_EQ(c.confidence.information_scale, cd.information_scale);
  EXPECT_EQ(c.confidence.inlier_ratio_ref, cd.inlier_ratio_ref);
  EXPECT_EQ(c.confidence.overlap_ref, cd.overlap_ref);
  EXPECT_EQ(c.confidence.conditioning_ref, cd.conditioning_ref);
  EXPECT_EQ(c.confidence.degeneracy_threshold, cd.degeneracy_threshold);
  EXPECT_EQ(c.confidence.color_inlier_threshold, cd.color_inlier_threshold);
}

TEST(RegistrationConfig, EveryShippedPresetLoadsAndNamesAShippedModel) {
  // config/presets/<kind>.yaml: the matcher of each data kind, read as obm-bench, obm-map and the
  // MRPT bridge read it; its model path is relative to the preset and names a shipped model.
  for (const char* kind : {"lidar", "rgbd_frames", "objects", "objects_noise", "objects_resampled",
                           "fragments"}) {
    SCOPED_TRACE(kind);
    const std::string file = obm::test::sourceDir() + "/config/presets/" + kind + ".yaml";
    const registration::ScanMatcherConfig c =
        registration::ScanMatcherConfig::load(ConfigNode::loadFile(file).child("matcher"));
    EXPECT_EQ(c.type, registration::MatcherKind::ObmNetIcp);
    EXPECT_NE(c.obmnet.network.model_path.find("/share/obmslam/models/obmnet_"), std::string::npos);
    EXPECT_GT(c.obmnet.search_candidates, 0);
  }
}

TEST(RegistrationConfig, PresetKeyReadsThePresetWithOverridesLaidOver) {
  // `preset:` (relative to the YAML naming it) gives the preset's matcher; keys beside it
  // replace the preset's one by one, nested maps merged key by key.
  const std::string dir = obm::test::sourceDir() + "/config";
  const auto plain = registration::ScanMatcherConfig::load(
      ConfigNode::loadFile(dir + "/presets/lidar.yaml").child("matcher"));
  const auto node = ConfigNode::fromString(R"(
preset: presets/lidar.yaml
obmnet:
  pre_align: true
  search: {cell: 2.0}
icp: {kernel_scale: 0.2}
)",
                                           dir + "/map_test.yaml");
  const auto c = registration::ScanMatcherConfig::load(node);
  EXPECT_EQ(c.type, plain.type);
  EXPECT_EQ(std::filesystem::path(c.obmnet.network.model_path).lexically_normal(),
            std::filesystem::path(plain.obmnet.network.model_path).lexically_normal());
  EXPECT_TRUE(c.obmnet.pre_align);
  EXPECT_FALSE(plain.obmnet.pre_align);
  EXPECT_EQ(c.obmnet.search.cell, 2.0);
  EXPECT_EQ(c.obmnet.search.heading_range_deg, plain.obmnet.search.heading_range_deg);
  EXPECT_EQ(c.obmnet.search_candidates, plain.obmnet.search_candidates);
  EXPECT_EQ(c.icp.kernel_scale, 0.2);
  EXPECT_EQ(c.icp.max_correspondence_distance, plain.icp.max_correspondence_distance);
  EXPECT_EQ(c.confidence.inlier_threshold, plain.confidence.inlier_threshold);
  // A missing preset and a misspelt override are named.
  try {
    registration::ScanMatcherConfig::load(
        ConfigNode::fromString("preset: presets/nowhere.yaml", dir + "/map_test.yaml"));
    ADD_FAILURE() << "a missing preset was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("nowhere.yaml"), std::string::npos) << e.what();
  }
  try {
    registration::ScanMatcherConfig::load(ConfigNode::fromString(
        "preset: presets/lidar.yaml\nicp: {kernel_scal: 0.2}", dir + "/map_test.yaml"));
    ADD_FAILURE() << "a misspelt override was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("kernel_scal"), std::string::npos) << e.what();
  }
}

#ifdef OBM_TEST_WITHOUT_OBMNET
TEST(RegistrationConfig, ObmNetTypesNeedLibTorch) {
  // This build has no LibTorch: the OBMNet matchers say so instead of failing later.
  registration::ScanMatcherConfig c;
  c.type = registration::MatcherKind::ObmNetIcp;
  c.obmnet.network.model_path = "any.pt";
  EXPECT_THROW(registration::makeScanMatcher(c), ConfigError);
  EXPECT_THROW(registration::ObmNetMatcher(c.obmnet), ConfigError);
}
#endif

}  // namespace
}  // namespace obm
