// obm-sim-bench: ray-casting throughput and memory of the simulator on its presets, printed as a
// Markdown table (docs/benchmarks.md, section "Simulator (obm-sim)").
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>

#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/timer.hpp"
#include "obm/sim/lidar.hpp"
#include "obm/sim/rgbd_camera.hpp"
#include "obm/sim/scene.hpp"
#include "obm/sim/scenes.hpp"
#include "obm/sim/simulator.hpp"

namespace {

double peakRssMiB() {
  struct rusage ru {};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_maxrss) / 1024.0;  // Linux: KiB
}

std::string loadAverage() {
  std::ifstream is("/proc/loadavg");
  std::string a;
  is >> a;
  return a.empty() ? "?" : a;
}

std::string fmt(double v, int prec) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

struct Row {
  std::string what, value, target, ok;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "obm-sim-bench: measures the simulator on its presets — HDL-64E sweeps per second and rays "
      "per second on kitti_like_urban, RGB-D 640x480 frames per second on indoor_loop, scene "
      "build times, peak memory, and optionally whole obm-sim runs with writing — and prints a "
      "Markdown table."};
  int sweeps = 100, frames = 100, threads = 0, e2e_frames = 0;
  std::string tmp_dir = std::filesystem::temp_directory_path().string();
  app.add_option("--sweeps", sweeps, "LiDAR sweeps to time [default: 100]");
  app.add_option("--frames", frames, "RGB-D frames to time [default: 100]");
  app.add_option("--threads", threads, "ray-casting threads, 0 = all cores [default: 0]");
  app.add_option("--end-to-end", e2e_frames,
                 "also time whole obm-sim runs (ray casting + writing every file) of this many "
                 "frames per preset [default: 0 = skip]");
  app.add_option("--tmp", tmp_dir, "folder for the end-to-end outputs (removed afterwards)");
  CLI11_PARSE(app, argc, argv);

  try {
    obm::setLogLevel(obm::LogLevel::Warn);
    using namespace obm::sim;
    std::vector<Row> rows;
    const unsigned hw = std::thread::hardware_concurrency();
    const std::string load_before = loadAverage();

    // --- LiDAR on the urban preset --------------------------------------------------------
    SimConfig urban = SimConfig::loadFile(findPreset("kitti_like_urban", argv[0]));
    urban.threads = threads;
    urban.applySeed();
    obm::Timer t;
    const GeneratedScene city = generateUrbanGrid(urban.scene.urban);
    const double t_city = t.seconds();
    t.reset();
    RaycastSceneOptions ro;
    ro.build_threads = threads;
    const RaycastScene city_rc(city.mesh, ro);
    const double t_bvh = t.seconds();
    const Trajectory drive = generateDrive(urban.scene.urban, city, urban.trajectory.drive);
    LidarParams lp = urban.sensor.lidar;
    lp.threads = threads;
    const LidarSimulator lidar(lp);
    std::size_t points = 0;
    lidar.simulate(city_rc, drive.poses[0], 0.0, 1);  // warm-up
    t.reset();
    for (int k = 0; k < sweeps; ++k) {
      const std::size_t i = (static_cast<std::size_t>(k) * 7) % drive.size();
      points += lidar.simulate(city_rc, drive.poses[i], drive.stamps[i], 100 + k).cloud.size();
    }
    const double t_lidar = t.seconds();
    const double sweeps_s = sweeps / t_lidar;
    const double rays_s = sweeps_s * static_cast<double>(lp.raysPerSweep());
    lp.motion_distortion = true;
    const LidarSimulator lidar_md(lp);
    const PoseAtTime pose = [&](double s) { return drive.interpolate(s); };
    t.reset();
    for (int k = 0; k < sweeps / 4 + 1; ++k) {
      const std::size_t i = (static_cast<std::size_t>(k) * 7) % drive.size();
      lidar_md.simulate(city_rc, pose, drive.stamps[i], 100 + k);
    }
    const double md_sweeps_s = (sweeps / 4 + 1) / t.seconds();
    const double rss_urban = peakRssMiB();
    rows.push_back({"urban scene (kitti_like_urban): generation", fmt(t_city, 2) + " s", "", ""});
    rows.push_back({"urban scene: triangles / Embree BVH build",
                    std::to_string(city.mesh.numFaces()) + " / " + fmt(t_bvh, 2) + " s", "", ""});
    rows.push_back({"HDL-64E rays per sweep", std::to_string(lp.raysPerSweep()), "~130k", ""});
    rows.push_back({"HDL-64E points per sweep (mean)", fmt(double(points) / sweeps, 0), "", ""});
    rows.push_back({"HDL-64E sweeps/s", fmt(sweeps_s, 1), ">= 10", sweeps_s >= 10 ? "yes" : "NO"});
    rows.push_back({"HDL-64E rays/s", fmt(rays_s / 1e6, 2) + " M", ">= 1.3 M",
                    rays_s >= 1.3e6 ? "yes" : "NO"});
    rows.push_back({"HDL-64E sweeps/s with motion distortion", fmt(md_sweeps_s, 1), "", ""});
    rows.push_back({"peak RSS after the urban scene + sweeps", fmt(rss_urban, 0) + " MiB",
                    "<= 2048 MiB", rss_urban <= 2048 ? "yes" : "NO"});

    // --- RGB-D on the indoor preset -------------------------------------------------------
    SimConfig indoor = SimConfig::loadFile(findPreset("indoor_loop", argv[0]));
    indoor.threads = threads;
    indoor.applySeed();
    t.reset();
    const GeneratedScene floor = generateIndoorFloor(indoor.scene.indoor);
    const RaycastScene floor_rc(floor.mesh, ro);
    const double t_floor = t.seconds();
    const Trajectory walk = generateWalk(indoor.scene.indoor, floor, indoor.trajectory.walk);
    RgbdParams cp = indoor.sensor.rgbd;
    cp.threads = threads;
    const RgbdSimulator cam(cp);
    cam.render(floor_rc, walk.poses[0], 0.0, 1);  // warm-up
    std::size_t valid = 0;
    t.reset();
    for (int k = 0; k < frames; ++k) {
      const std::size_t i = (static_cast<std::size_t>(k) * 13) % walk.size();
      valid += cam.render(floor_rc, walk.poses[i], walk.stamps[i], 200 + k).validCount();
    }
    const double t_rgbd = t.seconds();
    const double fps = frames / t_rgbd;
    rows.push_back({"indoor scene (indoor_loop): triangles / generation + BVH",
                    std::to_string(floor.mesh.numFaces()) + " / " + fmt(t_floor, 2) + " s", "",
                    ""});
    rows.push_back({"RGB-D 640x480 frames/s (noise, shadows, colour)", fmt(fps, 1), ">= 20",
                    fps >= 20 ? "yes" : "NO"});
    rows.push_back({"RGB-D valid pixels per frame (mean)", fmt(double(valid) / frames, 0), "", ""});
    cp.projector_shadow = false;
    cp.color = false;
    const RgbdSimulator cam2(cp);
    t.reset();
    for (int k = 0; k < frames; ++k) {
      const std::size_t i = (static_cast<std::size_t>(k) * 13) % walk.size();
      cam2.render(floor_rc, walk.poses[i], walk.stamps[i], 200 + k);
    }
    rows.push_back({"RGB-D frames/s without projector shadow and colour",
                    fmt(frames / t.seconds(), 1), "", ""});
    cp.noise = false;
    const RgbdSimulator cam3(cp);
    t.reset();
    for (int k = 0; k < frames; ++k) {
      const std::size_t i = (static_cast<std::size_t>(k) * 13) % walk.size();
      cam3.render(floor_rc, walk.poses[i], walk.stamps[i], 200 + k);
    }
    rows.push_back({"RGB-D frames/s, also without noise (ray casting only)",
                    fmt(frames / t.seconds(), 1), "", ""});

    // --- whole runs -----------------------------------------------------------------------
    if (e2e_frames > 0) {
      for (const char* preset : {"kitti_like_urban", "indoor_loop"}) {
        SimConfig c = SimConfig::loadFile(findPreset(preset, argv[0]));
        c.frames = static_cast<std::size_t>(e2e_frames);
        c.threads = threads;
        c.applySeed();
        const std::string out = tmp_dir + "/obm-sim-bench-" + preset;
        std::filesystem::remove_all(out);
        SequenceSimulator sim(c);
        SimOptions o;
        o.out_dir = out;
        o.progress = false;
        const SimSummary s = sim.run(o);
        std::filesystem::remove_all(out);
        rows.push_back({std::string("obm-sim --preset ") + preset + " --frames " +
                            std::to_string(e2e_frames) + ": frames/s incl. writing",
                        fmt(s.frames / s.seconds, 1), "", ""});
      }
    }

    std::cout << "| measurement | value | target | met |\n|---|---|---|---|\n";
    for (const auto& r : rows)
      std::cout << "| " << r.what << " | " << r.value << " | " << r.target << " | " << r.ok
                << " |\n";
    std::cout << "\nMachine: " << hw << " hardware threads, ray-casting threads "
              << (threads == 0 ? std::to_string(hw) + " (all)" : std::to_string(threads))
              << ", load average before / after: " << load_before << " / " << loadAverage()
              << "; peak RSS of the whole benchmark " << fmt(peakRssMiB(), 0) << " MiB.\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "obm-sim-bench: error: " << e.what() << "\n";
    return 1;
  }
}
