// draco-sim end to end: a short two-robot mission is written, then streamed back with the
// recording reader; a malformed mission fails with file and line.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "draco/recording/recording.hpp"

namespace {

namespace fs = std::filesystem;

int RunSim(const std::string& args, const fs::path& log) {
  const std::string cmd = std::string(DRACO_SIM_EXE) + " " + args + " > " + log.string() + " 2>&1";
  return std::system(cmd.c_str());
}

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(SimApp, WritesAMissionTheReaderStreamsBack) {
  const fs::path dir = fs::temp_directory_path() / "draco_sim_app_test";
  fs::remove_all(dir);
  const std::string mission = std::string(DRACO_SOURCE_DIR) + "/config/missions/marina.yaml";
  ASSERT_EQ(RunSim(mission + " --out " + (dir / "m").string() + " --duration-s 4 --robots 2",
                   dir.string() + ".log"),
            0)
      << ReadAll(dir.string() + ".log");
  EXPECT_TRUE(fs::exists(dir / "m" / "pictures" / "world.png"));

  const auto info = draco::recording::LoadMissionInfo(dir / "m");
  ASSERT_EQ(info.robots.size(), 2u);
  EXPECT_EQ(info.robots[0].name, "alpha");
  EXPECT_EQ(info.seed, 7u);
  EXPECT_EQ(info.sonar.num_beams, 512);
  auto reader = draco::recording::RobotReader::Open(dir / "m", "bravo");
  int pings = 0, dvl = 0, ahrs = 0, truth = 0;
  double last_time = -1.0;
  double last_truth_time = -1.0;
  while (auto record = reader.Next()) {
    const double t = draco::recording::RecordTime(*record);
    EXPECT_GE(t, last_time);
    last_time = t;
    if (auto* ping = std::get_if<draco::msgs::SonarPing>(&*record)) {
      ++pings;
      EXPECT_EQ(ping->num_ranges * ping->num_beams, static_cast<int>(ping->intensity.size()));
      EXPECT_EQ(ping->bearings_rad.size(), 512u);
    } else if (std::get_if<draco::msgs::DvlVelocity>(&*record)) {
      ++dvl;
    } else if (std::get_if<draco::msgs::Ahrs>(&*record)) {
      ++ahrs;
    } else if (auto* g = std::get_if<draco::msgs::GroundTruthPose>(&*record)) {
      ++truth;
      last_truth_time = g->time_s;
    }
  }
  EXPECT_EQ(pings, 21);  // 4 s at 5 Hz, both ends
  EXPECT_EQ(dvl, 21);
  EXPECT_EQ(ahrs, 401);
  EXPECT_EQ(truth, 81);
  EXPECT_DOUBLE_EQ(last_truth_time, 4.0);
  fs::remove_all(dir);
}

TEST(SimApp, MalformedMissionNamesFileAndLine) {
  const fs::path dir = fs::temp_directory_path() / "draco_sim_app_bad";
  fs::create_directories(dir);
  std::ofstream(dir / "bad.yaml") << "world: w.yaml\nrobots:\n  - name: a\n    start_m: [0, 0]\n"
                                     "    speed: 1\n";
  EXPECT_NE(RunSim((dir / "bad.yaml").string() + " --out " + (dir / "out").string(), dir / "log"),
            0);
  const std::string log = ReadAll(dir / "log");
  EXPECT_NE(log.find("bad.yaml:5:"), std::string::npos) << log;
  EXPECT_NE(log.find("unknown key 'speed'"), std::string::npos) << log;
  fs::remove_all(dir);
}

TEST(SimApp, GeneratesAMissionItCanSimulate) {
  const fs::path dir = fs::temp_directory_path() / "draco_sim_app_generate";
  fs::remove_all(dir);
  ASSERT_EQ(RunSim("generate --seed 4 --out " + (dir / "g").string(), dir.string() + ".log"), 0)
      << ReadAll(dir.string() + ".log");
  for (const char* f : {"world.yaml", "mission.yaml", "scenario.txt", "world.png"}) {
    EXPECT_TRUE(fs::exists(dir / "g" / f)) << f;
  }
  const std::string summary = ReadAll(dir / "g" / "scenario.txt");
  EXPECT_NE(summary.find("seed: 4\n"), std::string::npos) << summary;
  EXPECT_NE(summary.find("periodic: "), std::string::npos) << summary;
  // The same seed again, without the picture: the same files.
  ASSERT_EQ(
      RunSim("generate --seed 4 --no-picture --out " + (dir / "h").string(), dir.string() + ".log"),
      0);
  EXPECT_FALSE(fs::exists(dir / "h" / "world.png"));
  EXPECT_EQ(ReadAll(dir / "g" / "mission.yaml"), ReadAll(dir / "h" / "mission.yaml"));
  EXPECT_EQ(ReadAll(dir / "g" / "world.yaml"), ReadAll(dir / "h" / "world.yaml"));
  // draco-sim simulates it (2 s, one robot).
  ASSERT_EQ(RunSim((dir / "g" / "mission.yaml").string() + " --out " + (dir / "m").string() +
                       " --duration-s 2 --robots 1 --no-pictures",
                   dir.string() + ".log"),
            0)
      << ReadAll(dir.string() + ".log");
  const auto info = draco::recording::LoadMissionInfo(dir / "m");
  EXPECT_EQ(info.robots.size(), 1u);
  fs::remove_all(dir);
  fs::remove(dir.string() + ".log");
}

}  // namespace
