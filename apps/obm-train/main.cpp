// obm-train: unsupervised training of OBMNet from a YAML config (see docs/training.md).
#include <torch/torch.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <cstdio>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "../common/cli.hpp"
#include "obm/datasets/fragment_source.hpp"
#include "obm/datasets/object_source.hpp"
#include "obm/datasets/scan_source.hpp"
#include "obm/config/config_node.hpp"
#include "obm/config/overrides.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/obmnet/distributed.hpp"
#include "obm/obmnet/trainer.hpp"
#include "launcher.hpp"

int main(int argc, char** argv) {
  obm::apps::useFastMathLibraries(argv);
  CLI::App app{
      "obm-train: unsupervised training of OBMNet (L_g + L_n + L_s, optionally self-training\n"
      "labels from its own ICP-refined estimate; no ground truth).\n"
      "Writes OUT/checkpoint.pt (resume point), OUT/best.pt (best on the validation split),\n"
      "OUT/train_log.csv and OUT/config.yaml. Ctrl-C stops after the current batch; the\n"
      "checkpoint keeps the last whole epoch and --resume continues from it.\n"
      "Data-parallel: --nproc N starts N processes on this machine; on several machines start\n"
      "one obm-train per process with RANK, WORLD_SIZE, MASTER_ADDR and MASTER_PORT set\n"
      "(docs/training.md, \"Several processes\")."};
  std::string config_path, out_dir, data_dir;
  bool resume = false;
  int threads = 0, epochs = 0, measure = 0, overfit = 0, overfit_epoch = 0, batch = 0;
  bool validate_only = false;
  double max_hours = -1.0;
  std::string log_level;
  std::vector<std::string> overrides;
  app.add_option("-c,--config", config_path, "training config (YAML: model, train, data)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("-o,--out", out_dir, "output folder (created)")->required();
  app.add_flag("--resume", resume, "continue from OUT/checkpoint.pt if it exists");
  std::string init_model;
  app.add_option("--init", init_model,
                 "warm start: weights from this model file (e.g. a previous run's best.pt); "
                 "fresh optimiser and epoch count")
      ->check(CLI::ExistingFile);
  app.add_option("--threads", threads, "intra-op threads (default: train.threads of the config)");
  app.add_option("--epochs", epochs, "override train.epochs");
  app.add_option("--max-hours", max_hours, "override train.max_hours (0 = no limit)");
  app.add_option("--data", data_dir,
                 "override data.dir (mesh folder, or the folder of the KITTI sequences)");
  app.add_option("--measure", measure, "only measure training throughput on N batches and exit");
  app.add_flag("--validate", validate_only,
               "only score the model (--init, else a fresh one) on the validation pairs and exit: "
               "MIE(R), MIE(t), recall and the correspondence inlier ratio (train.inlier_radius)");
  app.add_option(
      "--overfit", overfit,
      "sanity check: N steps on one fixed batch of a fresh model, printing the rotation error");
  app.add_option(
      "--overfit-epoch", overfit_epoch,
      "curriculum level of the --overfit batch (default: the last epoch = the full protocol)");
  app.add_option("--batch-size", batch, "override train.batch_size");
  app.add_option("--set", overrides,
                 "override any config key, repeatable: --set model.use_nmm=false --set train.lr=5e-4 "
                 "(the value is YAML; OUT/config.yaml records the result)");
  int nproc = 0;
  std::string device, dist_file;
  app.add_option("--nproc", nproc,
                 "data-parallel training with N processes on this machine (ranks 1..N-1 log to "
                 "OUT/rank_K.log); the batch of train.batch_size pairs is split over them")
      ->check(CLI::Range(1, 256));
  app.add_option("--dist-file", dist_file,
                 "rendezvous of the ranks through this file (on a file system all of them see; "
                 "must not exist) instead of MASTER_ADDR:MASTER_PORT");
  app.add_option("--device", device, "override train.device: cpu or cuda:K");
  obm::apps::addLogLevelOption(app, log_level, "info");
  CLI11_PARSE(app, argc, argv);

  // Every exception, LibTorch's c10::Error included, is "obm-train: error: ...", exit code 1.
  return obm::apps::runMain("obm-train", obm::apps::OtherExceptions::Error, [&] {
    if (nproc > 1) {  // the launcher: the same command, without --nproc, once per rank
      std::vector<std::string> args{"/proc/self/exe"};
      for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--nproc") {
          ++i;
          continue;
        }
        if (a.rfind("--nproc=", 0) == 0) continue;
        args.push_back(a);
      }
      // The real path: /proc/self/exe of a child names the child itself.
      args[0] = std::filesystem::canonical("/proc/self/exe").string();
      return obm::apps::launchRanks(args, nproc, out_dir);
    }

    obm::setLogLevel(obm::parseLogLevel(log_level));
    OBM_LOG_DEBUG("obm-train", "math libraries: " << obm::apps::mathLibrarySettings());
    auto root = obm::ConfigNode::loadFile(config_path);
    obm::applyOverrides(root, overrides);
    // The command-line options are written into the document too, so that OUT/config.yaml is
    // the configuration this run really used and `-c OUT/config.yaml --resume` continues it.
    if (threads > 0) obm::setValue(root, "train.threads", YAML::Node(threads));
    if (epochs > 0) obm::setValue(root, "train.epochs", YAML::Node(epochs));
    if (max_hours >= 0) obm::setValue(root, "train.max_hours", YAML::Node(max_hours));
    if (batch > 0) obm::setValue(root, "train.batch_size", YAML::Node(batch));
    if (!data_dir.empty()) obm::setValue(root, "data.dir", YAML::Node(data_dir));
    if (!device.empty()) obm::setValue(root, "train.device", YAML::Node(device));
    auto dist = obm::obmnet::DistributedOptions::fromEnvironment();
    if (!dist_file.empty()) dist.init_file = dist_file;
    // Ranks other than 0 only report warnings (rank 0 prints the progress and the summary).
    if (dist.rank > 0 && obm::parseLogLevel(log_level) < obm::LogLevel::Warn)
      obm::setLogLevel(obm::LogLevel::Warn);
    auto cfg = obm::obmnet::TrainConfig::load(root);
    torch::set_num_threads(cfg.threads);

    // The data: meshes (object-level protocols) or LiDAR scan pairs (`source: kitti`).
    const auto data = root.child("data");
    std::string source = "cgal";
    data.get("source", source);
    std::unique_ptr<obm::obmnet::Trainer> trainer_ptr;
    if (source == "kitti") {
      auto scans = obm::datasets::ScanSourceConfig::load(data);
      // Inference cuts the road as the model file says (model.ground_band): the training pairs
      // must be cut the same way.
      if (scans.ground_band != cfg.model.ground_band)
        throw obm::ConfigError(config_path + ": data.ground_band (" +
                               std::to_string(scans.ground_band) + ") and model.ground_band (" +
                               std::to_string(cfg.model.ground_band) +
                               ") differ: the network would see roads at inference that training "
                               "removed, or the reverse");
      const int n_points = cfg.protocol.num_points;
      auto sampler = obm::datasets::scanPairSampler(scans, n_points, cfg.curriculum_epochs);
      auto val = obm::datasets::scanValidationPairs(scans, n_points, cfg.val_pairs, cfg.seed);
      std::fprintf(stderr, "[obm-train] scans: %zu validation pairs, %d points each\n", val.size(),
                   n_points);
      trainer_ptr =
          std::make_unique<obm::obmnet::Trainer>(cfg, std::move(sampler), std::move(val), out_dir);
    } else if (const auto src = obm::datasets::ObjectSourceConfig::load(data);
               src.source == "rgbd" && !src.rgbd.pair_gaps.empty()) {
      // Pairs of two different depth frames (data.rgbd.pair_gaps), not fragments cut twice.
      const auto& o = src.rgbd;
      const int n_points = cfg.protocol.num_points;
      auto sampler = obm::datasets::rgbdFramePairSampler(src.dir, o, n_points);
      auto val = obm::datasets::withPointCount(
          obm::datasets::rgbdFramePairs(src.dir, o, o.val_sequences, o.pair_gaps[0], o.pair_gaps[1],
                                    cfg.val_pairs, cfg.seed),
          n_points, cfg.seed);
      if (!o.start_near_label.empty()) {
        // Validation pairs start near their answer as the training pairs do: the ground truth
        // places them (it scores validation only), so the score is where a pass from a right
        // start ends.
        std::mt19937_64 rng(cfg.seed);
        for (auto& p : val)
          obm::datasets::startNearPose(p, p.T_target_source, o.start_near_label[0],
                                       o.start_near_label[1], rng);
      }
      std::fprintf(stderr, "[obm-train] RGB-D frame pairs: %zu validation pairs, %d points each\n",
                   val.size(), n_points);
      trainer_ptr =
          std::make_unique<obm::obmnet::Trainer>(cfg, std::move(sampler), std::move(val), out_dir);
    } else {
      auto set = obm::datasets::loadObjectSet(src);
      std::fprintf(stderr,
                   "[obm-train] objects: %zu train, %zu val, %zu test (test never used here)\n",
                   set.train.size(), set.val.size(), set.test.size());
      trainer_ptr = std::make_unique<obm::obmnet::Trainer>(cfg, std::move(set.train),
                                                           std::move(set.val), out_dir);
    }
    auto& trainer = *trainer_ptr;
    if (dist.world_size > 1) {
      trainer.setProcessGroup(std::make_shared<obm::obmnet::ProcessGroup>(dist));
      std::fprintf(stderr, "[obm-train] rank %d of %d, %d threads, batch %d split over the ranks\n",
                   dist.rank, dist.world_size, cfg.threads, cfg.batch_size);
    }
    {
      std::string header = "# obm-train's configuration of this run: " + config_path;
      for (const auto& o : overrides) header += " --set " + o;
      header +=
          ", with the command-line options applied.\n"
          "# Continue the run: obm-train -c OUT/config.yaml -o OUT --resume\n";
      trainer.setRunConfigYaml(header + obm::toYamlText(root));
    }
    if (!init_model.empty()) trainer.initializeFrom(init_model);
    if (overfit > 0) {
      const auto rows =
          trainer.overfitOneBatch(overfit, 5, overfit_epoch > 0 ? overfit_epoch : cfg.epochs);
      std::printf("step  loss       rotation error [deg]  translation error  mode\n");
      for (const auto& r : rows)
        std::printf("%4d  %-9.5f  %-20.6g  %-17.6g  %s\n", r.step, r.loss, r.rotation_error_deg,
                    r.translation_error, r.mode.c_str());
      return 0;
    }
    if (validate_only) {
      const auto v = trainer.validate();
      std::printf(
          "validation: MIE(R) %.4f deg  MIE(t) %.5f  recall %.3f  inlier ratio %.4f "
          "(radius %g)  mean alpha %.4g  loss %.5f\n",
          v.mie_r, v.mie_t, v.recall, v.inlier_ratio, cfg.inlier_radius,
          v.mean_alpha, v.loss);
      if (cfg.match_loss_weight > 0.0)
        std::printf("self-training teacher on these pairs: labels %.4f of the source points, "
                    "%.4f of them correct (radius %g), its pose MIE(R) %.4f deg\n",
                    v.teacher_labelled, v.teacher_precision, cfg.inlier_radius, v.teacher_mie_r);
      return 0;
    }
    if (measure > 0) {
      std::printf("training throughput: %.2f pairs/s (batch %d, %d threads)\n",
                  trainer.measureThroughput(measure), cfg.batch_size, cfg.threads);
      return 0;
    }
    const std::atomic<bool>& stop = obm::apps::installCancelHandler();
    const auto stats = trainer.run(resume, [&stop] { return stop.load(); });
    if (!stats.empty()) {
      const auto& s = stats.back();
      std::printf(
          "epoch %d: loss %.5f  val MIE(R) %.4f deg  MIE(t) %.5f  recall %.3f  inlier ratio %.4f  "
          "(%.0f s trained)\n",
          s.epoch, s.loss, s.val_mie_r, s.val_mie_t, s.val_recall, s.val_inlier_ratio, s.wall_s);
    }
    std::printf("model: %s/best.pt   log: %s/train_log.csv\n", out_dir.c_str(), out_dir.c_str());
    return stop ? 130 : 0;
  });
}
