// draco-sim: generates a recorded mission (sonar, DVL, AHRS, depth, ground truth) from a
// mission YAML, plus pictures of the world, the paths and sample sonar frames.
//
//   draco-sim MISSION.yaml --out DIR [--seed N] [--duration-s S] [--robots K]
//   draco-sim --world WORLD.yaml --picture out.png
//   draco-sim generate --seed N --out DIR [--style FILE.yaml] [--robots K] [--no-picture]
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "app_version.hpp"
#include "draco/sim/generator.hpp"
#include "draco/sim/mission.hpp"
#include "draco/sim/simulator.hpp"
#include "draco/sim/sonar_model.hpp"
#include "draco/sim/trajectory.hpp"
#include "draco/sim/world.hpp"
#include "log_option.hpp"
#include "mission_output.hpp"
#include "pictures.hpp"
#include "run_info.hpp"

namespace {

using draco::sim::Vec2;
using Clock = std::chrono::steady_clock;

// Forwards to the recording and keeps what the summary and pictures need.
class RobotRun : public draco::sim::RobotSink {
 public:
  RobotRun(std::string name, draco::sim_app::RecordingSink* out)
      : name_(std::move(name)), out_(out) {}

  void OnPing(const draco::msgs::SonarPing& ping,
              const draco::sim::TrajectorySample& truth) override {
    out_->OnPing(ping, truth);
    // Pixels above the CFAR absolute threshold, and a structure-rich frame to show.
    ++pings_;
    std::size_t bright = 0;
    for (auto v : ping.intensity) bright += v > 65;
    bright_pixels_ += bright;
    pixels_ += ping.intensity.size();
    if (bright > best_bright_) {
      best_bright_ = bright;
      best_frame_ = ping;
    }
    if (ping.ping_id % 300 == 150 && samples_.size() < 6) samples_.push_back(ping);
  }
  void OnDvl(const draco::msgs::DvlVelocity& dvl) override {
    dr_.AddDvl(dvl);
    out_->OnDvl(dvl);
  }
  void OnAhrs(const draco::msgs::Ahrs& ahrs) override {
    dr_.AddAhrs(ahrs);
    out_->OnAhrs(ahrs);
  }
  void OnDepth(const draco::msgs::Depth& depth) override { out_->OnDepth(depth); }
  void OnGroundTruth(const draco::msgs::GroundTruthPose& pose) override {
    out_->OnGroundTruth(pose);
    const Vec2 p{pose.position_m[0], pose.position_m[1]};
    if (!have_start_) {
      start_ = pose;
      have_start_ = true;
      path_.push_back(p);
      last_ = p;
    }
    distance_m_ += draco::sim::Norm(p - last_);
    last_ = p;
    if (draco::sim::Norm(p - path_.back()) > 0.2) path_.push_back(p);
    // Dead-reckoning error against ground truth, in the robot's start frame.
    const double dx = p.x - start_.position_m[0];
    const double dy = p.y - start_.position_m[1];
    const double c = std::cos(start_.yaw_rad);
    const double s = std::sin(start_.yaw_rad);
    last_error_m_ = std::hypot(c * dx + s * dy - dr_.x_m(), -s * dx + c * dy - dr_.y_m());
    max_error_m_ = std::max(max_error_m_, last_error_m_);
  }
  std::uint64_t pings() const { return pings_; }

  const std::string& name() const { return name_; }
  const std::vector<Vec2>& path() const { return path_; }
  double distance_m() const { return distance_m_; }
  double final_error_m() const { return last_error_m_; }
  double max_error_m() const { return max_error_m_; }
  double bright_fraction() const {
    return pixels_ == 0 ? 0.0 : static_cast<double>(bright_pixels_) / pixels_;
  }
  const draco::msgs::SonarPing& best_frame() const { return best_frame_; }
  const std::vector<draco::msgs::SonarPing>& samples() const { return samples_; }

 private:
  std::string name_;
  draco::sim_app::RecordingSink* out_;
  draco::sim::DeadReckoning dr_;
  draco::msgs::GroundTruthPose start_;
  Vec2 last_;
  std::uint64_t pings_ = 0;
  bool have_start_ = false;
  std::vector<Vec2> path_;
  double distance_m_ = 0.0;
  double last_error_m_ = 0.0;
  double max_error_m_ = 0.0;
  std::size_t bright_pixels_ = 0;
  std::size_t pixels_ = 0;
  std::size_t best_bright_ = 0;
  draco::msgs::SonarPing best_frame_;
  std::vector<draco::msgs::SonarPing> samples_;
};

std::string Duration(double seconds) {
  char buf[32];
  const int s = static_cast<int>(std::lround(std::max(0.0, seconds)));
  std::snprintf(buf, sizeof(buf), "%dm%02ds", s / 60, s % 60);
  return buf;
}

// Fraction of a robot's ping positions within radius_m of another robot's path.
double Overlap(const std::vector<Vec2>& mine, const std::vector<std::vector<Vec2>>& others,
               double radius_m) {
  if (mine.empty()) return 0.0;
  std::size_t near = 0;
  for (std::size_t i = 0; i < mine.size(); i += 5) {
    bool found = false;
    for (const auto& other : others) {
      for (std::size_t j = 0; j < other.size() && !found; j += 5) {
        found = draco::sim::Norm(other[j] - mine[i]) < radius_m;
      }
      if (found) break;
    }
    near += found;
  }
  return static_cast<double>(near) / ((mine.size() + 4) / 5);
}

int RunMission(const std::string& mission_file, const std::string& out_dir,
               std::optional<std::uint64_t> seed, std::optional<double> duration_s,
               std::optional<int> robots, int threads, bool pictures, bool sonar_on,
               int ping_quantization_step, draco::app::RunInfo run_info) {
  const auto t_start = Clock::now();
  draco::sim::Mission mission = draco::sim::LoadMission(mission_file);
  if (seed) mission.seed = *seed;
  if (duration_s) mission.duration_s = *duration_s;
  if (robots) {
    if (*robots < 1 || *robots > static_cast<int>(mission.robots.size())) {
      throw std::invalid_argument("--robots " + std::to_string(*robots) + ": " + mission_file +
                                  " defines " + std::to_string(mission.robots.size()) + " robots");
    }
    mission.robots.resize(static_cast<std::size_t>(*robots));
  }
  const draco::sim::World world = draco::sim::LoadWorld(mission.world_path);
  const draco::sim::SonarModel sonar(world, mission.sonar);
  const int n = static_cast<int>(mission.robots.size());
  std::vector<int> indices(n);
  for (int i = 0; i < n; ++i) indices[i] = i;

  std::cout << "draco-sim: mission '" << mission.name << "' in world '" << world.name << "' ("
            << world.primitives.size() << " primitives), " << n << " robots, seed " << mission.seed
            << ", out " << out_dir << "\n";

  draco::recording::WriterOptions writer_options;
  writer_options.ping_quantization_step = ping_quantization_step;
  draco::sim_app::MissionOutput output(out_dir, mission, indices, writer_options);
  run_info.AddFile("mission", mission_file);
  draco::app::WriteRunInfo(out_dir, run_info);
  std::vector<std::unique_ptr<draco::sim_app::RecordingSink>> sinks;
  std::vector<std::unique_ptr<RobotRun>> runs;
  std::vector<draco::sim::RobotProgress> progress(n);
  for (int i = 0; i < n; ++i) {
    sinks.push_back(output.OpenRobot(i));
    runs.push_back(std::make_unique<RobotRun>(mission.robots[i].name, sinks.back().get()));
  }

  // Robots run on worker threads (one robot per thread at a time); a robot's output is
  // independent of which thread runs it.
  std::mutex mutex;
  std::condition_variable done_cv;
  int next_robot = 0;
  int finished = 0;
  std::exception_ptr error;
  auto worker = [&]() {
    for (;;) {
      int i = 0;
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (next_robot >= n || error) return;
        i = next_robot++;
      }
      try {
        draco::sim::SimulateRobot(world, mission, i, sonar_on ? &sonar : nullptr, *runs[i],
                                  &progress[i]);
        sinks[i]->Close();
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!error) error = std::current_exception();
      }
      {
        std::lock_guard<std::mutex> lock(mutex);
        ++finished;
      }
      done_cv.notify_all();
    }
  };
  const int n_threads = threads > 0 ? std::min(threads, n) : n;
  std::vector<std::thread> pool;
  for (int t = 0; t < n_threads; ++t) pool.emplace_back(worker);

  const bool tty = isatty(STDOUT_FILENO) != 0;
  const auto period = tty ? std::chrono::milliseconds(500) : std::chrono::milliseconds(5000);
  for (;;) {
    std::unique_lock<std::mutex> lock(mutex);
    const bool all_done = done_cv.wait_for(lock, period, [&] { return finished == n; });
    lock.unlock();
    std::uint64_t done = 0;
    std::uint64_t total = 0;
    std::ostringstream line;
    for (int i = 0; i < n; ++i) {
      const auto d = progress[i].pings_done.load();
      const auto t = std::max<std::uint64_t>(1, progress[i].pings_total.load());
      done += d;
      total += t;
      line << mission.robots[i].name << " " << Duration(progress[i].mission_time_s.load()) << " "
           << 100 * d / t << "%  ";
    }
    const double elapsed = std::chrono::duration<double>(Clock::now() - t_start).count();
    const double rate = done / std::max(1e-3, elapsed);
    const double eta = rate > 0 ? (static_cast<double>(total) - done) / rate : 0.0;
    char tail[96];
    std::snprintf(tail, sizeof(tail), "| %.0f pings/s, elapsed %s, ETA %s", rate,
                  Duration(elapsed).c_str(), Duration(eta).c_str());
    if (tty) {
      std::cout << "\r" << line.str() << tail << "   " << std::flush;
    } else {
      std::cout << line.str() << tail << "\n" << std::flush;
    }
    if (all_done) break;
  }
  if (tty) std::cout << "\n";
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  output.Close();
  const double gen_s = std::chrono::duration<double>(Clock::now() - t_start).count();

  // Summary.
  std::ostringstream summary;
  summary << "mission " << mission.name << ", world " << world.name << ", seed " << mission.seed
          << ", generated in " << gen_s << " s with " << n_threads << " threads\n";
  for (int i = 0; i < n; ++i) {
    std::vector<std::vector<Vec2>> others;
    for (int j = 0; j < n; ++j) {
      if (j != i) others.push_back(runs[j]->path());
    }
    const RobotRun& r = *runs[i];
    const double dist = std::max(1e-9, r.distance_m());
    char buf[320];
    std::snprintf(buf, sizeof(buf),
                  "  %-8s %6zu pings  %6.1f m  dead reckoning: final error %.2f m (%.2f %%), "
                  "max %.2f m  pixels>65 %.3f %%  overlap(10 m) %.0f %%\n",
                  r.name().c_str(), static_cast<std::size_t>(r.pings()), r.distance_m(),
                  r.final_error_m(), 100.0 * r.final_error_m() / dist, r.max_error_m(),
                  100.0 * r.bright_fraction(), 100.0 * Overlap(r.path(), others, 10.0));
    summary << buf;
  }
  std::cout << summary.str();

  if (pictures) {
    const std::filesystem::path pic_dir = std::filesystem::path(out_dir) / "pictures";
    std::vector<draco::sim_app::PathDrawing> paths;
    for (const auto& r : runs) paths.push_back({r->name(), r->path()});
    draco::sim_app::WriteWorldPicture(world, paths, pic_dir / "world.png");
    for (const auto& r : runs) {
      if (!r->best_frame().intensity.empty()) {
        draco::sim_app::WritePolarPicture(r->best_frame(),
                                          pic_dir / (r->name() + "_best_polar.png"));
        draco::sim_app::WriteFanPicture(r->best_frame(), pic_dir / (r->name() + "_best_fan.png"));
      }
      for (const auto& ping : r->samples()) {
        const std::string stem = r->name() + "_ping" + std::to_string(ping.ping_id);
        draco::sim_app::WritePolarPicture(ping, pic_dir / (stem + "_polar.png"));
        draco::sim_app::WriteFanPicture(ping, pic_dir / (stem + "_fan.png"));
      }
    }
    std::ofstream(pic_dir / "summary.txt") << summary.str();
    std::cout << "pictures in " << pic_dir.string() << "\n";
  }
  return 0;
}

// Draws a world and mission and writes DIR/{world.yaml, mission.yaml, scenario.txt, world.png}.
int RunGenerate(std::uint64_t seed, const std::string& out_dir, const std::string& style_file,
                std::optional<int> robots, bool picture, draco::app::RunInfo run_info) {
  const auto t_start = Clock::now();
  draco::sim::GeneratorOptions options;
  if (!style_file.empty()) options = draco::sim::LoadGeneratorOptions(style_file);
  if (robots) options.robots = {*robots, *robots};
  const draco::sim::Scenario scenario = draco::sim::GenerateScenario(options, seed);
  const double gen_ms = 1e3 * std::chrono::duration<double>(Clock::now() - t_start).count();

  const std::filesystem::path dir(out_dir);
  std::filesystem::create_directories(dir);
  if (!style_file.empty()) run_info.AddFile("style", style_file);
  draco::app::WriteRunInfo(dir, run_info);
  auto write = [&](const char* name, const std::string& text) {
    std::ofstream out(dir / name);
    out << text;
    if (!out) throw std::runtime_error((dir / name).string() + ": cannot write");
  };
  write("world.yaml", scenario.world_yaml);
  write("mission.yaml", scenario.mission_yaml);
  write("scenario.txt", scenario.summary);
  // Read back with the simulator's own loaders.
  const draco::sim::World world = draco::sim::LoadWorld(dir / "world.yaml");
  const draco::sim::Mission mission = draco::sim::LoadMission(dir / "mission.yaml");
  if (picture) {
    std::vector<draco::sim_app::PathDrawing> paths;
    for (const auto& r : mission.robots) paths.push_back({r.name, draco::sim::PatternPath(r)});
    draco::sim_app::WriteWorldPicture(world, paths, dir / "world.png");
  }
  std::cout << "draco-sim generate: style " << scenario.style << ", seed " << seed << ": "
            << scenario.objects << " objects (" << world.primitives.size() << " primitives), "
            << mission.robots.size() << " robots, periodic " << (scenario.periodic ? "yes" : "no")
            << ", generated in " << std::fixed << std::setprecision(1) << gen_ms << " ms\n"
            << "wrote " << (dir / "world.yaml").string() << ", mission.yaml, scenario.txt"
            << (picture ? ", world.png" : "") << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-sim: forward-looking sonar mission simulator"};
  draco::app::AddLogLevelOption(app);
  app.fallthrough();  // --log-level after `generate` too
  std::string mission_file;
  std::string out_dir;
  std::string world_file;
  std::string picture;
  std::uint64_t seed = 0;
  double duration_s = 0.0;
  int robots = 0;
  int threads = 0;  // 0: one thread per robot
  bool no_pictures = false;
  bool no_sonar = false;
  int ping_quantization_step = 1;
  app.add_option("mission", mission_file, "mission YAML (config/missions/*.yaml)");
  auto* out_opt = app.add_option("--out", out_dir, "output mission directory");
  auto* seed_opt = app.add_option("--seed", seed, "override the mission seed");
  auto* duration_opt = app.add_option("--duration-s", duration_s, "cap each robot's duration");
  auto* robots_opt = app.add_option("--robots", robots, "simulate only the first K robots");
  app.add_option("--threads", threads,
                 "worker threads; robots run in parallel (default: one per robot)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--no-pictures", no_pictures, "skip the PNG pictures");
  app.add_option("--ping-quantization-step", ping_quantization_step,
                 "store each ping intensity as its nearest multiple of Q (lossy, smaller files; "
                 "docs/recording-format.md); default 1: exact")
      ->check(CLI::Range(1, 128));
  app.add_flag("--no-sonar", no_sonar,
               "navigation and ground truth only (fast; for designing missions)");
  auto* world_opt = app.add_option("--world", world_file, "world YAML, with --picture");
  app.add_option("--picture", picture, "write a PNG of --world and exit")->needs(world_opt);

  auto* generate = app.add_subcommand(
      "generate", "draw a harbour-like world and multi-robot mission (docs/simulator.md)");
  std::uint64_t gen_seed = 0;
  std::string gen_out;
  std::string gen_style;
  int gen_robots = 0;
  bool gen_picture = true;
  generate->add_option("--seed", gen_seed, "seed: the same seed gives the same files")->required();
  generate->add_option("--out", gen_out, "output folder")->required();
  generate->add_option("--style", gen_style,
                       "style YAML (default: built-in, config/generator/harbour.yaml)");
  auto* gen_robots_opt =
      generate->add_option("--robots", gen_robots, "number of robots (default: style's range)")
          ->check(CLI::Range(1, 8));
  generate->add_flag("--picture,!--no-picture", gen_picture,
                     "write DIR/world.png with the planned paths (default: on)");
  app.set_version_flag("--version", draco::app::VersionLine("draco-sim"));
  CLI11_PARSE(app, argc, argv);
  const auto run_info = draco::app::MakeRunInfo("draco-sim", argc, argv);

  try {
    if (generate->parsed()) {
      return RunGenerate(gen_seed, gen_out, gen_style,
                         gen_robots_opt->count() ? std::optional<int>(gen_robots) : std::nullopt,
                         gen_picture, run_info);
    }
    if (!picture.empty()) {
      const draco::sim::World world = draco::sim::LoadWorld(world_file);
      draco::sim_app::WriteWorldPicture(world, {}, picture);
      std::cout << "wrote " << picture << " (" << world.primitives.size() << " primitives)\n";
      return 0;
    }
    if (mission_file.empty() || out_opt->count() == 0) {
      draco::log::Error(
          "draco-sim: give MISSION.yaml and --out DIR (or --world W --picture P, or generate "
          "--seed N --out DIR)");
      return 2;
    }
    return RunMission(mission_file, out_dir,
                      seed_opt->count() ? std::optional<std::uint64_t>(seed) : std::nullopt,
                      duration_opt->count() ? std::optional<double>(duration_s) : std::nullopt,
                      robots_opt->count() ? std::optional<int>(robots) : std::nullopt, threads,
                      !no_pictures, !no_sonar, ping_quantization_step, run_info);
  } catch (const std::exception& e) {
    draco::log::Error(std::string("draco-sim: ") + e.what());
    return 1;
  }
}
