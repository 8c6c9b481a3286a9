// report::EvaluatePlacements on a hand-made two-robot run folder: the true map-to-map
// transform from each robot's trajectory and ground truth, verdicts over time, path overlap and
// the shared objects that make a pair eligible, all against hand-computed values.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "draco/report/placements.hpp"

namespace fs = std::filesystem;
using draco::report::EvaluatePlacements;
using draco::report::PairPlacement;

namespace {

constexpr double kPi = std::numbers::pi;

struct Pose {
  double t, x, y, yaw;
};

std::string Tum(const std::vector<Pose>& rows) {
  std::ostringstream os;
  os.precision(12);
  os << "# t x y z qx qy qz qw\n";
  for (const auto& r : rows) {
    os << r.t << " " << r.x << " " << r.y << " 0 0 0 " << std::sin(r.yaw / 2) << " "
       << std::cos(r.yaw / 2) << "\n";
  }
  return os.str();
}

std::string Num(double v) {
  std::ostringstream os;
  os.precision(15);
  os << v;
  return os.str();
}

void Write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// A point of the world expressed in a map frame placed at (x, y, yaw) in the world.
std::array<double, 2> ToMap(const Pose& T_world_map, double xw, double yw) {
  const double c = std::cos(T_world_map.yaw), s = std::sin(T_world_map.yaw);
  const double dx = xw - T_world_map.x, dy = yw - T_world_map.y;
  return {c * dx + s * dy, -s * dx + c * dy};
}

class PlacementsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("draco_placements_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // alpha's map frame is the world; bravo's sits at (10, 0) turned by 90 deg.
    const std::vector<Pose> alpha_truth{{0, 0, 0, 0}, {1, 5, 0, 0}, {2, 10, 0, 0}, {3, 15, 0, 0}};
    const std::vector<Pose> bravo_truth{
        {0, 0, 1, 0}, {1, 5, 1, 0}, {2, 10, 1, 0}, {3, 40, 40, 0}};  // the last is far away
    std::vector<Pose> bravo_kf;
    for (const auto& p : bravo_truth) {
      const auto m = ToMap(bravo_map_, p.x, p.y);
      bravo_kf.push_back({p.t, m[0], m[1], p.yaw - bravo_map_.yaw});
    }
    Write(dir_ / "alpha.trajectory.tum", Tum(alpha_truth));
    Write(dir_ / "alpha.ground_truth.tum", Tum(alpha_truth));
    Write(dir_ / "bravo.trajectory.tum", Tum(bravo_kf));
    Write(dir_ / "bravo.ground_truth.tum", Tum(bravo_truth));
    // alpha places bravo 3 m off at t = 1 (wrong), 0.5 m off at t = 2 (right). The true
    // T_alpha_bravo is bravo's map in the world: (10, 0, 90 deg).
    Write(dir_ / "alpha.placements.csv",
          "time_s,teammate,placed,x_m,y_m,yaw_rad,map_expected,map_misses\n"
          "1.0,bravo,1,13.0,0.0," +
              Num(kPi / 2) +
              ",0,0\n"
              "2.0,bravo,1,10.5,0.0," +
              Num(kPi / 2) + ",0,0\n");
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Objects at world points; bravo's written in its own map frame.
  void WriteObjects(const std::string& robot, const std::vector<std::array<double, 2>>& world) {
    std::string s = "id,center_x_m,center_y_m,length_m,breadth_m,yaw_rad,num_points\n";
    int id = 0;
    for (const auto& w : world) {
      const auto m = robot == "bravo" ? ToMap(bravo_map_, w[0], w[1]) : w;
      s += std::to_string(id++) + "," + std::to_string(m[0]) + "," + std::to_string(m[1]) +
           ",1.0,1.0,0.0,30\n";
    }
    Write(dir_ / (robot + ".objects.csv"), s);
  }

  const PairPlacement& Pair(const draco::report::PlacementResult& r, const std::string& own) {
    for (const auto& p : r.pairs)
      if (p.own == own) return p;
    throw std::runtime_error("no pair");
  }

  fs::path dir_;
  const Pose bravo_map_{0, 10.0, 0.0, kPi / 2};
};

TEST_F(PlacementsTest, VerdictsOverTimeAgainstTheTrueMapToMapTransform) {
  const auto r = EvaluatePlacements(dir_.string(), "", {"alpha", "bravo"});
  ASSERT_TRUE(r.problems.empty()) << r.problems.front();
  ASSERT_EQ(r.pairs.size(), 2u);
  const auto& ab = Pair(r, "alpha");
  EXPECT_EQ(ab.teammate, "bravo");
  EXPECT_STREQ(ab.Verdict(), "right");
  EXPECT_NEAR(ab.final_err_m, 0.5, 1e-6);  // a pure 0.5 m shift: every keyframe 0.5 m off
  EXPECT_NEAR(ab.final_err_deg, 0.0, 1e-6);
  EXPECT_DOUBLE_EQ(ab.first_placed_s, 1.0);
  EXPECT_DOUBLE_EQ(ab.first_wrong_s, 1.0);
  EXPECT_DOUBLE_EQ(ab.first_right_s, 2.0);
  EXPECT_NEAR(ab.wrong_duration_s, 1.0, 1e-9);  // wrong from t = 1 until the change at t = 2
  EXPECT_NEAR(ab.max_wrong_err_m, 3.0, 1e-6);
  EXPECT_EQ(ab.changes, 2);
  // 3 of bravo's 4 true keyframes lie within 10 m of alpha's path; all of alpha's near bravo's.
  EXPECT_DOUBLE_EQ(ab.path_overlap, 0.75);
  EXPECT_STREQ(Pair(r, "bravo").Verdict(), "none");  // bravo wrote no placements
  EXPECT_DOUBLE_EQ(Pair(r, "bravo").path_overlap, 1.0);
  // Without object maps nothing is shared and no pair is eligible.
  EXPECT_EQ(ab.shared_objects, -1);
  EXPECT_FALSE(ab.eligible);
}

TEST_F(PlacementsTest, APairIsEligibleWithFiveSharedObjectsAndOverlappingPaths) {
  // Five objects both robots mapped (bravo's 0.8 m off: its own map error), one each alone.
  WriteObjects("alpha", {{0, 5}, {5, 5}, {10, 5}, {15, 5}, {20, 5}, {-30, -30}});
  WriteObjects("bravo", {{0.8, 5}, {5, 5.8}, {10, 5}, {15, 4.2}, {19.2, 5}, {30, 30}});
  auto r = EvaluatePlacements(dir_.string(), "", {"alpha", "bravo"});
  EXPECT_EQ(Pair(r, "alpha").shared_objects, 5);
  EXPECT_EQ(Pair(r, "bravo").shared_objects, 5);
  EXPECT_TRUE(Pair(r, "alpha").eligible);
  EXPECT_TRUE(Pair(r, "bravo").eligible);
  // One object moved 2.5 m away: 4 shared, below the minimum of 5.
  WriteObjects("bravo", {{0.8, 5}, {5, 5.8}, {10, 5}, {15, 4.2}, {22.5, 5}, {30, 30}});
  r = EvaluatePlacements(dir_.string(), "", {"alpha", "bravo"});
  EXPECT_EQ(Pair(r, "alpha").shared_objects, 4);
  EXPECT_FALSE(Pair(r, "alpha").eligible);
  // Five shared again, but the paths overlap too little for the options' minimum.
  WriteObjects("bravo", {{0.8, 5}, {5, 5.8}, {10, 5}, {15, 4.2}, {19.2, 5}, {30, 30}});
  draco::report::PlacementJudgeOptions options;
  options.min_path_overlap = 0.8;
  r = EvaluatePlacements(dir_.string(), "", {"alpha", "bravo"}, options);
  EXPECT_EQ(Pair(r, "alpha").shared_objects, 5);
  EXPECT_FALSE(Pair(r, "alpha").eligible);  // 0.75 < 0.8
  EXPECT_TRUE(Pair(r, "bravo").eligible);   // 1.0
}

TEST_F(PlacementsTest, AMalformedObjectMapIsAProblemNamingTheFile) {
  Write(dir_ / "alpha.objects.csv", "id,x,y\n0,1,2\n");  // no center_x_m column
  const auto r = EvaluatePlacements(dir_.string(), "", {"alpha", "bravo"});
  ASSERT_FALSE(r.problems.empty());
  EXPECT_NE(r.problems.front().find("alpha.objects.csv"), std::string::npos) << r.problems.front();
  EXPECT_FALSE(Pair(r, "alpha").eligible);
}

}  // namespace
