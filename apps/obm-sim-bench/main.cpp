// obm-sim-bench: ray-casting throughput and memory of the simulator on its presets, printed as a
// Markdown table (docs/benchmarks.md, section "Simulator (obm-sim)").
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>

#include "../common/cli.hpp"
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

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
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

// Wall and process-CPU time of a block of `items` work items.
struct Span {
  double wall = 0, cpu = 0;
  int items = 0;
  double wallRate() const { return items / wall; }
  /// Items per second if `cores` cores were free for it (CPU time is what the work costs,
  /// whatever else runs on the machine).
  double freeRate(int cores) const { return cores * items / cpu; }
};

template <typename F>
Span measure(int items, F&& f) {
  obm::Timer t;
  const double c0 = processCpuSeconds();
  for (int k = 0; k < items; ++k) f(k);
  return {t.seconds(), processCpuSeconds() - c0, items};
}

struct Row {
  std::string what, wall, cpu, free, target, ok;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "obm-sim-bench: measures the simulator on its presets — HDL-64E sweeps per second and rays "
      "per second on kitti_like_urban, RGB-D 640x480 frames per second on indoor_loop, scene "
      "build times, peak memory, and optionally whole obm-sim runs with writing — and prints a "
      "Markdown table with wall-clock rates, CPU time per item, and the rate the CPU time implies "
      "on the machine's cores when nothing else runs."};
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

  return obm::apps::runMain("obm-sim-bench", obm::apps::OtherExceptions::Error, [&] {
    obm::setLogLevel(obm::LogLevel::Warn);
    using namespace obm::sim;
    const int hw = std::max(1u, std::thread::hardware_concurrency());
    const int cores = threads > 0 ? std::min(threads, hw) : hw;
    std::vector<Row> rows;
    auto rate = [&](const std::string& what, const Span& s, const std::string& unit,
                    double target) {
      const double free = s.freeRate(cores);
      rows.push_back({what, fmt(s.wallRate(), 1) + unit, fmt(1e3 * s.cpu / s.items, 1) + " ms",
                      fmt(free, 1) + unit, target > 0 ? ">= " + fmt(target, 0) + unit : "",
                      target > 0 ? (free >= target ? "yes" : "NO") : ""});
    };
    auto info = [&](const std::string& what, const std::string& value,
                    const std::string& target = "", const std::string& ok = "") {
      rows.push_back({what, value, "", "", target, ok});
    };
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
    auto pose_of = [&](int k) { return (static_cast<std::size_t>(k) * 7) % drive.size(); };
    lidar.simulate(city_rc, drive.poses[0], 0.0, 1);  // warm-up
    const Span ls = measure(sweeps, [&](int k) {
      points += lidar.simulate(city_rc, drive.poses[pose_of(k)], drive.stamps[pose_of(k)], 100 + k)
                    .cloud.size();
    });
    lp.motion_distortion = true;
    const LidarSimulator lidar_md(lp);
    const PoseAtTime pose = [&](double s) { return drive.interpolate(s); };
    const Span lsd = measure(std::max(1, sweeps / 4), [&](int k) {
      lidar_md.simulate(city_rc, pose, drive.stamps[pose_of(k)], 100 + k);
    });
    const double rss_urban = peakRssMiB();
    info("urban scene (kitti_like_urban): triangles", std::to_string(city.mesh.numFaces()));
    info("urban scene: generation / Embree BVH build",
         fmt(t_city, 2) + " s / " + fmt(t_bvh, 2) + " s");
    info("HDL-64E rays per sweep / mean points per sweep",
         std::to_string(lp.raysPerSweep()) + " / " + fmt(double(points) / sweeps, 0), "~130k rays");
    rate("HDL-64E sweeps/s", ls, "", 10);
    Span lr = ls;
    lr.items = static_cast<int>(ls.items * lp.raysPerSweep() / 1000);
    rows.push_back({"HDL-64E rays/s", fmt(lr.wallRate() / 1e3, 2) + " M",
                    fmt(1e6 * ls.cpu / (double(ls.items) * lp.raysPerSweep()), 3) + " µs/ray",
                    fmt(lr.freeRate(cores) / 1e3, 2) + " M", ">= 1.3 M",
                    lr.freeRate(cores) >= 1300 ? "yes" : "NO"});
    rate("HDL-64E sweeps/s with motion distortion", lsd, "", 0);
    info("peak RSS after the urban scene + sweeps", fmt(rss_urban, 0) + " MiB", "<= 2048 MiB",
         rss_urban <= 2048 ? "yes" : "NO");

    // --- RGB-D on the indoor preset -------------------------------------------------------
    SimConfig indoor = SimConfig::loadFile(findPreset("indoor_loop", argv[0]));
    indoor.threads = threads;
    indoor.applySeed();
    t.reset();
    const GeneratedScene floor = generateIndoorFloor(indoor.scene.indoor);
    const RaycastScene floor_rc(floor.mesh, ro);
    const double t_floor = t.seconds();
    const Trajectory walk = generateWalk(indoor.scene.indoor, floor, indoor.trajectory.walk);
    auto view = [&](int k) { return (static_cast<std::size_t>(k) * 13) % walk.size(); };
    RgbdParams cp = indoor.sensor.rgbd;
    cp.threads = threads;
    std::size_t valid = 0;
    const RgbdSimulator cam(cp);
    cam.render(floor_rc, walk.poses[0], 0.0, 1);  // warm-up
    const Span rs = measure(frames, [&](int k) {
      valid +=
          cam.render(floor_rc, walk.poses[view(k)], walk.stamps[view(k)], 200 + k).validCount();
    });
    info("indoor scene (indoor_loop): triangles / generation + BVH",
         std::to_string(floor.mesh.numFaces()) + " / " + fmt(t_floor, 2) + " s");
    rate("RGB-D 640x480 frames/s (noise, projector shadows, colour)", rs, "", 20);
    info("RGB-D valid depth pixels per frame (mean)", fmt(double(valid) / frames, 0));
    cp.projector_shadow = false;
    cp.color = false;
    const RgbdSimulator cam2(cp);
    rate("RGB-D frames/s without shadows and colour",
         measure(frames,
                 [&](int k) {
                   cam2.render(floor_rc, walk.poses[view(k)], walk.stamps[view(k)], 200 + k);
                 }),
         "", 0);
    cp.noise = false;
    const RgbdSimulator cam3(cp);
    rate("RGB-D frames/s, also without noise (ray casting only)",
         measure(frames,
                 [&](int k) {
                   cam3.render(floor_rc, walk.poses[view(k)], walk.stamps[view(k)], 200 + k);
                 }),
         "", 0);

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
        SimSummary s;
        const Span e = measure(1, [&](int) { s = sim.run(o); });
        std::filesystem::remove_all(out);
        Span per_frame = e;
        per_frame.items = static_cast<int>(s.frames);
        rate(std::string("obm-sim --preset ") + preset + " --frames " + std::to_string(e2e_frames) +
                 ": frames/s incl. scene, writing",
             per_frame, "", 0);
      }
    }

    std::cout << "| measurement | wall clock | CPU per item | on " << cores
              << " free cores | target | met |\n|---|---|---|---|---|---|\n";
    for (const auto& r : rows)
      std::cout << "| " << r.what << " | " << r.wall << " | " << r.cpu << " | " << r.free << " | "
                << r.target << " | " << r.ok << " |\n";
    std::cout << "\nMachine: " << hw << " hardware threads, ray casting on " << cores
              << " thread(s); load average before / after: " << load_before << " / "
              << loadAverage() << "; peak RSS of the whole benchmark " << fmt(peakRssMiB(), 0)
              << " MiB. \"On free cores\" = cores × items / process CPU time.\n";
    return 0;
  });
}
