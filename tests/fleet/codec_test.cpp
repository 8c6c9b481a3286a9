// Fleet codec: round trips within the quantisation steps, bounds, truncation, garbage, deltas.
#include "draco/fleet/codec.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>

#include "largest_allocation.hpp"

namespace draco::fleet {
namespace {

using msgs::Point2;
using msgs::Pose2;

const CodecOptions kO;

msgs::FleetHeader Header(int robot = 2) {
  return {.robot_id = robot, .incarnation = 0xdeadbeef, .seq = 1234, .time_s = 1234.567};
}

void ExpectHeader(const msgs::FleetHeader& a, const msgs::FleetHeader& b) {
  EXPECT_EQ(a.robot_id, b.robot_id);
  EXPECT_EQ(a.incarnation, b.incarnation);
  EXPECT_EQ(a.seq, b.seq);
  EXPECT_NEAR(a.time_s, b.time_s, kO.time_step_s / 2 + 1e-9);
}

double AngleDiff(double a, double b) {
  return std::abs(std::remainder(a - b, 2 * std::numbers::pi));
}

void ExpectPose(const Pose2& a, const Pose2& b) {
  EXPECT_NEAR(a.x_m, b.x_m, kO.position_step_m / 2 + 1e-9);
  EXPECT_NEAR(a.y_m, b.y_m, kO.position_step_m / 2 + 1e-9);
  EXPECT_LE(AngleDiff(a.yaw_rad, b.yaw_rad), kO.yaw_step_rad / 2 + 1e-9);
}

// A sonar-like scan: points along a few line segments and arcs, in the keyframe frame.
std::vector<Point2> Scan(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Point2> pts;
  while (static_cast<int>(pts.size()) < n) {
    const double x0 = 5 + 25 * (u(rng) + 1), y0 = 20 * u(rng), a = 3 * u(rng);
    for (int i = 0; i < 40 && static_cast<int>(pts.size()) < n; ++i)
      pts.push_back(
          {x0 + 0.2 * i * std::cos(a) + 0.03 * u(rng), y0 + 0.2 * i * std::sin(a) + 0.03 * u(rng)});
  }
  return pts;
}

msgs::Object Obj(std::uint32_t id, double x, double y) {
  msgs::Object o;
  o.id = id;
  o.center = {x, y};
  o.rect_center = {x + 0.3, y - 0.2};
  o.length_m = 6.3;
  o.breadth_m = 1.7;
  o.yaw_rad = 2.5;
  o.num_points = 150 + static_cast<int>(id);
  o.keyframes = {1, 2, 3};
  return o;
}

msgs::ObjectMap Map30() {
  msgs::ObjectMap m;
  m.robot_id = 1;
  m.time_s = 300;
  for (std::uint32_t i = 0; i < 30; ++i)
    m.objects.push_back(Obj(3 * i + 1, 10.0 * i - 120.0, 40.0 * std::sin(i)));
  return m;
}

void ExpectObject(const msgs::Object& a, const msgs::Object& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_NEAR(a.center.x_m, b.center.x_m, kO.position_step_m / 2 + 1e-9);
  EXPECT_NEAR(a.center.y_m, b.center.y_m, kO.position_step_m / 2 + 1e-9);
  EXPECT_NEAR(a.rect_center.x_m, b.rect_center.x_m, kO.position_step_m + 1e-9);
  EXPECT_NEAR(a.rect_center.y_m, b.rect_center.y_m, kO.position_step_m + 1e-9);
  EXPECT_NEAR(a.length_m, b.length_m, kO.size_step_m / 2 + 1e-9);
  EXPECT_NEAR(a.breadth_m, b.breadth_m, kO.size_step_m / 2 + 1e-9);
  const double dyaw = std::abs(std::remainder(a.yaw_rad - b.yaw_rad, std::numbers::pi));
  EXPECT_LE(dyaw, std::numbers::pi / 256 / 2 + 1e-9);
  EXPECT_GE(b.yaw_rad, 0.0);
  EXPECT_LT(b.yaw_rad, std::numbers::pi);
  EXPECT_EQ(a.num_points, b.num_points);
}

msgs::Heartbeat MakeHeartbeat() {
  msgs::Heartbeat h;
  h.header = Header();
  h.num_keyframes = 345;
  h.acks = {{0, 77, 12}, {1, 0xffffffff, 0}};
  h.transforms = {{2, {12.5, -40.25, 2.5}}};
  return h;
}

msgs::ObjectMapUpdate MakeObjectUpdate() {
  msgs::ObjectMapUpdate u;
  u.header = Header();
  u.version = 7;
  u.base_version = 5;
  u.upserts = Map30().objects;
  std::swap(u.upserts[0], u.upserts[5]);  // any order in, sorted by id out
  u.removed = {900, 17, 4000000000u};
  return u;
}

msgs::KeyframePoses MakePoses() {
  msgs::KeyframePoses p;
  p.header = Header();
  p.full = true;
  for (int i = 0; i < 50; ++i)
    p.poses.push_back({.index = 2 * i + (i % 3 == 0 ? 1 : 0),
                       .time_s = 10.0 + 2.5 * i,
                       .T_map_kf = {3.0 * std::cos(0.1 * i) - 50, 2.0 * i,
                                    std::remainder(0.3 * i, 2 * std::numbers::pi)},
                       .num_points = 100 + i});
  return p;
}

msgs::ScanRequest MakeRequest() {
  msgs::ScanRequest r;
  r.header = Header();
  r.target_robot = 1;
  r.object_map_version = 9;
  r.T_requester_target = {-123.456, 78.9, -3.0};
  r.object_ids = {40, 3, 17, 1000, 4};
  r.max_scans = 20;
  return r;
}

msgs::ScanReply MakeReply(int n = 300, std::uint32_t seed = 5) {
  std::mt19937 rng(seed);
  msgs::ScanReply r;
  r.header = Header();
  r.requester_robot = 0;
  r.keyframe = 321;
  r.keyframe_time_s = 987.654;
  r.T_map_kf = {12.3, -45.6, 1.2};
  r.points_kf = Scan(rng, n);
  return r;
}

msgs::Covariance3 Cov(double sx, double sy, double st, double rxy, double rxt, double ryt) {
  return {sx * sx,       rxy * sx * sy, rxt * sx * st, rxy * sx * sy, sy * sy,
          ryt * sy * st, rxt * sx * st, ryt * sy * st, st * st};
}

msgs::LoopClosureMessage MakeLoops() {
  msgs::LoopClosureMessage m;
  m.header = Header();
  m.target_robot = 0;
  const std::vector<msgs::Covariance3> covs = {
      Cov(0.1, 0.2, 0.01, 0.3, -0.2, 0.1), Cov(1e-3, 5.0, 0.5, 0.0, 0.0, 0.0),
      Cov(0.3, 0.3, 0.02, 0.999, 0.0, 0.0), Cov(0.05, 0.07, 0.003, -0.95, 0.9, -0.9)};
  for (int i = 0; i < 8; ++i) {
    msgs::InterRobotLoop l;
    l.id = 100 + static_cast<std::uint64_t>(i) * 3;
    l.own_robot = 2;
    l.own_keyframe = 40 + i;
    l.teammate_robot = 0;
    l.teammate_keyframe = 500 - i;
    l.T_ownkf_teammatekf = {1.5 * i, -2.0, 0.4 * i - 1};
    l.covariance = covs[static_cast<std::size_t>(i) % covs.size()];
    l.overlap = 0.1 * i;
    l.flags = msgs::kLoopAccepted;
    m.loops.push_back(l);
  }
  return m;
}

// Every decoder on one payload, for the fuzz and truncation loops (checks bounds on success).
template <typename M>
void ExpectWithinBounds(const M&) {}

void ExpectWithinBounds(const msgs::ScanReply& r) {
  const Bounds b;
  EXPECT_LE(static_cast<int>(r.points_kf.size()), b.max_points);
  for (const auto& p : r.points_kf) {
    EXPECT_LE(std::abs(p.x_m), b.max_abs_coordinate_m + 1);
    EXPECT_LE(std::abs(p.y_m), b.max_abs_coordinate_m + 1);
  }
}
void ExpectWithinBounds(const msgs::ObjectMapUpdate& u) {
  const Bounds b;
  EXPECT_LE(static_cast<int>(u.upserts.size()), b.max_objects);
  EXPECT_LE(static_cast<int>(u.removed.size()), b.max_objects);
  for (const auto& o : u.upserts) {
    EXPECT_TRUE(std::isfinite(o.center.x_m) &&
                std::abs(o.center.x_m) <= b.max_abs_coordinate_m + 1);
    EXPECT_TRUE(o.length_m >= 0 && o.length_m <= b.max_object_side_m + 1);
  }
}

// ---------------------------------------------------------------------------------------
// Round trips

TEST(FleetCodec, HeartbeatRoundTrip) {
  const auto h = MakeHeartbeat();
  const auto bytes = Encode(h);
  msgs::Heartbeat d;
  ASSERT_TRUE(Decode(bytes, &d)) << Decode(bytes, &d).error;
  ExpectHeader(h.header, d.header);
  EXPECT_EQ(d.num_keyframes, 345);
  ASSERT_EQ(d.acks.size(), 2u);
  EXPECT_EQ(d.acks[1].incarnation, 0xffffffffu);
  EXPECT_EQ(d.acks[0].object_map_version, 12u);
  EXPECT_EQ(d.acks[0].incarnation, 77u);
  ASSERT_EQ(d.transforms.size(), 1u);
  EXPECT_EQ(d.transforms[0].robot_id, 2);
  ExpectPose(h.transforms[0].T_sender_robot, d.transforms[0].T_sender_robot);
  EXPECT_LE(bytes.size(), 32u);
}

TEST(FleetCodec, ObjectMapRoundTrip) {
  const auto u = MakeObjectUpdate();
  const auto bytes = Encode(u);
  msgs::ObjectMapUpdate d;
  const auto res = Decode(bytes, &d);
  ASSERT_TRUE(res) << res.error;
  ExpectHeader(u.header, d.header);
  EXPECT_EQ(d.version, 7u);
  EXPECT_EQ(d.base_version, 5u);
  auto sorted = u.upserts;
  std::sort(sorted.begin(), sorted.end(), [](auto& a, auto& b) { return a.id < b.id; });
  ASSERT_EQ(d.upserts.size(), sorted.size());
  for (std::size_t i = 0; i < sorted.size(); ++i) ExpectObject(sorted[i], d.upserts[i]);
  EXPECT_EQ(d.removed, (std::vector<std::uint32_t>{17, 900, 4000000000u}));
  // Yaw wraps to [0, pi).
  msgs::ObjectMapUpdate w;
  w.upserts = {Obj(1, 0, 0), Obj(2, 0, 0), Obj(3, 0, 0)};
  w.upserts[0].yaw_rad = -0.5;
  w.upserts[1].yaw_rad = std::numbers::pi - 1e-4;
  w.upserts[2].yaw_rad = 7.0;
  ASSERT_TRUE(Decode(Encode(w), &d));
  EXPECT_NEAR(d.upserts[0].yaw_rad, std::numbers::pi - 0.5, 0.01);
  EXPECT_NEAR(d.upserts[1].yaw_rad, 0.0, 1e-9);
  EXPECT_NEAR(d.upserts[2].yaw_rad, 7.0 - 2 * std::numbers::pi, 0.01);
  // An empty update.
  msgs::ObjectMapUpdate e;
  e.header = Header();
  ASSERT_TRUE(Decode(Encode(e), &d));
  EXPECT_TRUE(d.upserts.empty() && d.removed.empty());
  EXPECT_TRUE(std::isnan(d.map_heading_rad));  // no heading: none decoded
  // The map's heading in 12 bits: within 0.05 deg, wrapped to (-pi, pi].
  for (const double heading : {0.0, 1.234, -2.5, 3.1, 7.0, -3.14159}) {
    e.map_heading_rad = heading;
    const auto with = Encode(e);
    ASSERT_TRUE(Decode(with, &d));
    EXPECT_NEAR(std::remainder(d.map_heading_rad - heading, 2 * std::numbers::pi), 0.0, 0.0009)
        << heading;
    EXPECT_GT(d.map_heading_rad, -std::numbers::pi - 1e-12);
    EXPECT_LE(d.map_heading_rad, std::numbers::pi + 1e-12);
  }
}

TEST(FleetCodec, LandmarkObjectsKeepTheirFlagThroughTheId) {
  msgs::ObjectMapUpdate u;
  u.header = Header();
  u.upserts = {Obj(3, 1.0, 2.0), Obj(msgs::kLandmarkIdBit + 5, 10.0, -4.0)};
  u.upserts[1].landmark = true;
  u.upserts[1].length_m = u.upserts[1].breadth_m = 1.2;
  msgs::ObjectMapUpdate d;
  const auto bytes = Encode(u);
  ASSERT_TRUE(Decode(bytes, &d));
  ASSERT_EQ(d.upserts.size(), 2u);
  EXPECT_FALSE(d.upserts[0].landmark);
  EXPECT_TRUE(d.upserts[1].landmark);
  EXPECT_EQ(d.upserts[1].id, msgs::kLandmarkIdBit + 5);
  EXPECT_NEAR(d.upserts[1].center.x_m, 10.0, kO.position_step_m);
  // A flag that disagrees with the id is refused at encoding, naming the object.
  u.upserts[0].landmark = true;
  try {
    Encode(u);
    ADD_FAILURE() << "encoded a landmark flag on a cluster id";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("object 3"), std::string::npos) << e.what();
  }
}

TEST(FleetCodec, KeyframePosesRoundTrip) {
  const auto p = MakePoses();
  const auto bytes = Encode(p);
  msgs::KeyframePoses d;
  const auto res = Decode(bytes, &d);
  ASSERT_TRUE(res) << res.error;
  ExpectHeader(p.header, d.header);
  EXPECT_TRUE(d.full);
  ASSERT_EQ(d.poses.size(), p.poses.size());
  for (std::size_t i = 0; i < p.poses.size(); ++i) {
    EXPECT_EQ(d.poses[i].index, p.poses[i].index);
    EXPECT_EQ(d.poses[i].num_points, p.poses[i].num_points);
    EXPECT_NEAR(d.poses[i].time_s, p.poses[i].time_s, kO.time_step_s / 2 + 1e-9);
    ExpectPose(p.poses[i].T_map_kf, d.poses[i].T_map_kf);
  }
  // Deltas make it far smaller than 3 doubles per pose.
  EXPECT_LT(bytes.size() * 8, p.poses.size() * 64);
}

TEST(FleetCodec, ScanRequestRoundTrip) {
  const auto r = MakeRequest();
  msgs::ScanRequest d;
  const auto res = Decode(Encode(r), &d);
  ASSERT_TRUE(res) << res.error;
  ExpectHeader(r.header, d.header);
  EXPECT_EQ(d.target_robot, 1);
  EXPECT_EQ(d.object_map_version, 9u);
  ExpectPose(r.T_requester_target, d.T_requester_target);
  EXPECT_EQ(d.object_ids, r.object_ids);  // order kept: most useful first
  EXPECT_EQ(d.max_scans, 20);
}

// Points come back as a set: match each decoded point to a distinct original within the step.
void ExpectSameSet(std::vector<Point2> a, std::vector<Point2> b, double step) {
  ASSERT_EQ(a.size(), b.size());
  const auto key = [step](const Point2& p) {
    return std::make_pair(std::llround(p.x_m / step), std::llround(p.y_m / step));
  };
  std::vector<std::pair<long long, long long>> ka, kb;
  for (const auto& p : a) ka.push_back(key(p));
  for (const auto& p : b) {
    kb.push_back(key(p));
    // Decoded points lie on the grid.
    EXPECT_NEAR(p.x_m / step, std::round(p.x_m / step), 1e-6);
  }
  std::sort(ka.begin(), ka.end());
  std::sort(kb.begin(), kb.end());
  EXPECT_EQ(ka, kb);
}

TEST(FleetCodec, ScanReplyRoundTrip) {
  for (const bool compress : {false, true}) {
    for (const int n : {0, 1, 2, 50, 300, 4096}) {
      CodecOptions o;
      o.compress_points = compress;
      const auto r = MakeReply(n, static_cast<std::uint32_t>(n));
      const auto bytes = Encode(r, o);
      msgs::ScanReply d;
      const auto res = Decode(bytes, &d, o);
      ASSERT_TRUE(res) << res.error;
      ExpectHeader(r.header, d.header);
      EXPECT_EQ(d.requester_robot, 0);
      EXPECT_EQ(d.keyframe, 321);
      EXPECT_NEAR(d.keyframe_time_s, r.keyframe_time_s, o.time_step_s / 2 + 1e-9);
      ExpectPose(r.T_map_kf, d.T_map_kf);
      ExpectSameSet(r.points_kf, d.points_kf, o.point_step_m);
      if (n >= 300) {
        EXPECT_LT(bytes.size() * 8, static_cast<std::size_t>(n) * 16);  // < 16 bit/pt
      }
    }
  }
  // Another point step.
  CodecOptions coarse;
  coarse.point_step_m = 0.2;
  const auto r = MakeReply(500);
  msgs::ScanReply d;
  ASSERT_TRUE(Decode(Encode(r, coarse), &d, coarse));
  ExpectSameSet(r.points_kf, d.points_kf, 0.2);
  EXPECT_LT(Encode(r, coarse).size(), Encode(r).size());
}

// Points at the coordinate bound, and duplicates after quantisation.
TEST(FleetCodec, ScanReplyExtremePoints) {
  msgs::ScanReply r = MakeReply(3);
  const double m = Bounds{}.max_abs_coordinate_m;
  r.points_kf = {{m, -m}, {-m, m}, {0.001, 0.002}, {0.0, 0.0}, {-m, -m}};
  msgs::ScanReply d;
  const auto res = Decode(Encode(r), &d);
  ASSERT_TRUE(res) << res.error;
  ExpectSameSet(r.points_kf, d.points_kf, kO.point_step_m);
}

TEST(FleetCodec, LoopClosuresRoundTrip) {
  const auto m = MakeLoops();
  const auto bytes = Encode(m);
  msgs::LoopClosureMessage d;
  const auto res = Decode(bytes, &d);
  ASSERT_TRUE(res) << res.error;
  ExpectHeader(m.header, d.header);
  ASSERT_EQ(d.loops.size(), m.loops.size());
  for (std::size_t i = 0; i < m.loops.size(); ++i) {
    const auto& a = m.loops[i];
    const auto& b = d.loops[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.own_robot, b.own_robot);
    EXPECT_EQ(a.own_keyframe, b.own_keyframe);
    EXPECT_EQ(a.teammate_robot, b.teammate_robot);
    EXPECT_EQ(a.teammate_keyframe, b.teammate_keyframe);
    EXPECT_EQ(a.flags, b.flags);
    EXPECT_NEAR(a.overlap, b.overlap, 0.5 / 255 + 1e-9);
    ExpectPose(a.T_ownkf_teammatekf, b.T_ownkf_teammatekf);
    // Documented tolerance: sigmas within 2.2 % (log2 step 1/16), correlations within 0.002
    // (0.01 when shrunk to stay positive definite), symmetric, positive definite.
    for (int k = 0; k < 3; ++k) {
      const double sa = std::sqrt(a.covariance[4 * k]), sb = std::sqrt(b.covariance[4 * k]);
      EXPECT_NEAR(sb / sa, 1.0, 0.022) << "loop " << i << " sigma " << k;
    }
    const auto rho = [](const msgs::Covariance3& c, int r, int col) {
      return c[3 * r + col] / std::sqrt(c[4 * r] * c[4 * col]);
    };
    for (const auto& [r, c] : {std::pair{0, 1}, {0, 2}, {1, 2}}) {
      EXPECT_NEAR(rho(a.covariance, r, c), rho(b.covariance, r, c), 0.01) << "loop " << i;
      EXPECT_EQ(b.covariance[3 * r + c], b.covariance[3 * c + r]);
    }
    // Positive definite: Sylvester's criterion.
    const auto& c = b.covariance;
    const double d2 = c[0] * c[4] - c[1] * c[3];
    const double d3 = c[0] * (c[4] * c[8] - c[5] * c[7]) - c[1] * (c[3] * c[8] - c[5] * c[6]) +
                      c[2] * (c[3] * c[7] - c[4] * c[6]);
    EXPECT_GT(c[0], 0);
    EXPECT_GT(d2, 0);
    EXPECT_GT(d3, 0);
  }
  EXPECT_LT(bytes.size() * 8, m.loops.size() * 160);
}

// ---------------------------------------------------------------------------------------
// Bounds

void ExpectThrows(const std::function<void()>& f, const std::string& what) {
  try {
    f();
    ADD_FAILURE() << "no exception, expected: " << what;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(FleetCodec, EncodeRefusesBoundViolations) {
  {
    auto h = MakeHeartbeat();
    h.header.robot_id = 64;
    ExpectThrows([&] { Encode(h); }, "heartbeat: robot_id 64");
    h = MakeHeartbeat();
    h.acks.resize(64);
    ExpectThrows([&] { Encode(h); }, "acks exceed the bound 63");
    h = MakeHeartbeat();
    h.header.time_s = 2e6;
    ExpectThrows([&] { Encode(h); }, "header time");
    h.header.time_s = std::nan("");
    ExpectThrows([&] { Encode(h); }, "not finite");
  }
  {
    auto u = MakeObjectUpdate();
    u.upserts.resize(2049);
    ExpectThrows([&] { Encode(u); }, "object_map: 2049 upserts exceed the bound 2048");
    u = MakeObjectUpdate();
    u.upserts[3].center.x_m = 3e4;
    ExpectThrows([&] { Encode(u); }, "object centre");
    u = MakeObjectUpdate();
    u.upserts[3].length_m = 600;
    ExpectThrows([&] { Encode(u); }, "object length");
    u = MakeObjectUpdate();
    u.upserts[3].breadth_m = -1;
    ExpectThrows([&] { Encode(u); }, "negative");
    u = MakeObjectUpdate();
    u.upserts[3].id = u.upserts[4].id;
    ExpectThrows([&] { Encode(u); }, "twice");
    u = MakeObjectUpdate();
    u.upserts[3].yaw_rad = INFINITY;
    ExpectThrows([&] { Encode(u); }, "yaw");
  }
  {
    auto p = MakePoses();
    std::swap(p.poses[3], p.poses[4]);
    ExpectThrows([&] { Encode(p); }, "ascending");
    p = MakePoses();
    p.poses[2].T_map_kf.y_m = -1e5;
    ExpectThrows([&] { Encode(p); }, "keyframe_poses: keyframe y");
    p = MakePoses();
    p.poses.back().index = 20001;
    ExpectThrows([&] { Encode(p); }, "keyframe index 20001");
    p = MakePoses();
    p.poses[0].num_points = 5000;
    ExpectThrows([&] { Encode(p); }, "num_points");
  }
  {
    auto r = MakeRequest();
    r.object_ids.resize(257);
    ExpectThrows([&] { Encode(r); }, "scan_request: 257 object_ids");
    r = MakeRequest();
    r.target_robot = -1;
    ExpectThrows([&] { Encode(r); }, "target_robot");
    r = MakeRequest();
    r.max_scans = -1;
    ExpectThrows([&] { Encode(r); }, "max_scans");
  }
  {
    auto s = MakeReply(4097);
    ExpectThrows([&] { Encode(s); }, "scan_reply: 4097 points exceed the bound 4096");
    s = MakeReply(10);
    s.points_kf[5].x_m = std::nan("");
    ExpectThrows([&] { Encode(s); }, "point x is not finite");
    s = MakeReply(10);
    s.keyframe = -3;
    ExpectThrows([&] { Encode(s); }, "keyframe -3");
  }
  {
    auto l = MakeLoops();
    l.loops[1].covariance = {};
    ExpectThrows([&] { Encode(l); }, "not positive definite");
    l = MakeLoops();
    l.loops[1].covariance[1] += 1e-3;
    ExpectThrows([&] { Encode(l); }, "not symmetric");
    l = MakeLoops();  // a solver's rounding (a few ulps) is not an asymmetry
    l.loops[1].covariance[1] *= 1.0 + 1e-14;
    EXPECT_NO_THROW(Encode(l));
    l = MakeLoops();
    l.loops[1].overlap = 1.5;
    ExpectThrows([&] { Encode(l); }, "overlap");
    l = MakeLoops();
    l.loops.resize(257, l.loops[0]);
    ExpectThrows([&] { Encode(l); }, "257 loops");
    l = MakeLoops();
    l.loops[0].teammate_robot = 99;
    ExpectThrows([&] { Encode(l); }, "teammate_robot 99");
  }
  CodecOptions bad;
  bad.point_step_m = 0;
  ExpectThrows([&] { Encode(MakeReply(3), bad); }, "steps");
}

template <typename M>
void ExpectRejected(const std::vector<std::uint8_t>& bytes, const Bounds& b,
                    const std::string& what) {
  M m;
  const auto res = Decode(bytes, &m, CodecOptions{}, b);
  EXPECT_FALSE(res);
  EXPECT_NE(res.error.find(what), std::string::npos) << "got: " << res.error;
}

// The decoder checks the bounds it is given (a teammate with other bounds, or garbage).
TEST(FleetCodec, DecodeRejectsBoundViolations) {
  Bounds b;
  b.max_robot_id = 1;
  ExpectRejected<msgs::Heartbeat>(Encode(MakeHeartbeat()), b,
                                  "heartbeat: robot_id 2 outside [0, 1]");
  ExpectRejected<msgs::ScanRequest>(Encode(MakeRequest()), b, "scan_request: robot_id 2");
  b = {};
  b.max_acks = 1;
  ExpectRejected<msgs::Heartbeat>(Encode(MakeHeartbeat()), b,
                                  "heartbeat: 2 acks exceed the bound 1");
  b = {};
  b.max_keyframes = 300;
  ExpectRejected<msgs::Heartbeat>(Encode(MakeHeartbeat()), b, "num_keyframes 345 outside");
  ExpectRejected<msgs::ScanReply>(Encode(MakeReply()), b, "scan_reply: keyframe 321 outside");
  b.max_keyframes = 10;
  ExpectRejected<msgs::KeyframePoses>(Encode(MakePoses()), b, "keyframe_poses: 50 poses exceed");
  b.max_keyframes = 60;
  ExpectRejected<msgs::KeyframePoses>(Encode(MakePoses()), b, "keyframe index");
  b = {};
  b.max_objects = 29;
  ExpectRejected<msgs::ObjectMapUpdate>(Encode(MakeObjectUpdate()), b,
                                        "object_map: 30 upserts exceed the bound 29");
  b = {};
  b.max_abs_coordinate_m = 100;
  ExpectRejected<msgs::ObjectMapUpdate>(Encode(MakeObjectUpdate()), b, "object centre x");
  ExpectRejected<msgs::ScanRequest>(Encode(MakeRequest()), b, "T_requester_target");
  b.max_abs_coordinate_m = 50;
  ExpectRejected<msgs::ScanReply>(Encode(MakeReply()), b, "scan_reply: points");
  ExpectRejected<msgs::KeyframePoses>(Encode(MakePoses()), b, "keyframe x");
  b = {};
  b.max_object_side_m = 5;
  ExpectRejected<msgs::ObjectMapUpdate>(Encode(MakeObjectUpdate()), b, "object length");
  b = {};
  b.max_time_s = 1000;
  ExpectRejected<msgs::Heartbeat>(Encode(MakeHeartbeat()), b, "header time");
  b = {};
  b.max_points = 100;
  ExpectRejected<msgs::ScanReply>(Encode(MakeReply()), b,
                                  "scan_reply: 300 points exceed the bound 100");
  ExpectRejected<msgs::KeyframePoses>(Encode(MakePoses()), b, "keyframe num_points");
  b = {};
  b.max_object_ids = 4;
  ExpectRejected<msgs::ScanRequest>(Encode(MakeRequest()), b, "5 object_ids exceed the bound 4");
  b = {};
  b.max_loops = 7;
  ExpectRejected<msgs::LoopClosureMessage>(Encode(MakeLoops()), b, "loop_closures: 8 loops exceed");
  // Bytes left over.
  auto bytes = Encode(MakeHeartbeat());
  bytes.push_back(0);
  ExpectRejected<msgs::Heartbeat>(bytes, Bounds{}, "left over");
  bytes = Encode(MakeReply());
  bytes.push_back(0x80);
  ExpectRejected<msgs::ScanReply>(bytes, Bounds{}, "scan_reply: points");
}

// ---------------------------------------------------------------------------------------
// Truncation at every length, and garbage

template <typename M>
void ExpectEveryPrefixRejected(const std::vector<std::uint8_t>& bytes, const CodecOptions& o = {}) {
  M m;
  ASSERT_TRUE(Decode(bytes, &m, o));
  for (std::size_t len = 0; len < bytes.size(); ++len) {
    const std::vector<std::uint8_t> prefix(bytes.begin(), bytes.begin() + static_cast<long>(len));
    M d;
    const auto res = Decode(prefix, &d, o);
    EXPECT_FALSE(res) << "prefix of " << len << " of " << bytes.size() << " bytes accepted";
    EXPECT_FALSE(res.error.empty());
  }
}

TEST(FleetCodec, TruncatedPayloadsRejectedAtEveryLength) {
  ExpectEveryPrefixRejected<msgs::Heartbeat>(Encode(MakeHeartbeat()));
  ExpectEveryPrefixRejected<msgs::ObjectMapUpdate>(Encode(MakeObjectUpdate()));
  ExpectEveryPrefixRejected<msgs::KeyframePoses>(Encode(MakePoses()));
  ExpectEveryPrefixRejected<msgs::ScanRequest>(Encode(MakeRequest()));
  ExpectEveryPrefixRejected<msgs::LoopClosureMessage>(Encode(MakeLoops()));
  CodecOptions raw;
  raw.compress_points = false;
  ExpectEveryPrefixRejected<msgs::ScanReply>(Encode(MakeReply(), raw), raw);
  ExpectEveryPrefixRejected<msgs::ScanReply>(Encode(MakeReply()));
  // A scan that deflate shrinks (a regular grid), so the deflated path is truncated too.
  msgs::ScanReply grid = MakeReply(0);
  for (int i = 0; i < 400; ++i) grid.points_kf.push_back({0.05 * (i % 20), 0.05 * (i / 20)});
  const auto gb = Encode(grid);
  EXPECT_LT(gb.size(), 100u);
  ExpectEveryPrefixRejected<msgs::ScanReply>(gb);
  // The empty payload names the kind.
  msgs::ScanReply d;
  EXPECT_NE(Decode({}, &d).error.find("scan_reply: truncated"), std::string::npos)
      << Decode({}, &d).error;
}

// Memory bound (docs/hardening.md): a count is checked against Bounds (20000 keyframes) and
// then only sizes a vector as far as the bits left can hold values (one bit each at least).
// Before, a 12-byte payload claiming 20000 poses reserved 160 kB per field.
TEST(FleetCodec, CountsFromThePayloadDoNotSizeBuffersBeyondItsBits) {
  msgs::KeyframePoses many;
  many.header = Header();
  for (int i = 0; i < 20000; ++i) many.poses.push_back({i, 0.5 * i, {0.01 * i, 0.0, 0.0}, 10});
  auto bytes = Encode(many);
  ASSERT_GT(bytes.size(), 1000u);
  bytes.resize(12);  // the header and the count, then a few values
  msgs::KeyframePoses d;
  const test_support::LargestAllocation largest;
  const auto res = Decode(bytes, &d);
  EXPECT_FALSE(res);
  EXPECT_NE(res.error.find("keyframe_poses: truncated"), std::string::npos) << res.error;
  if (test_support::LargestAllocation::Supported()) {
    EXPECT_LT(largest.bytes(), 1024u);
  }
}

template <typename M>
int FuzzDecode(const std::vector<std::uint8_t>& bytes) {
  M m;
  const auto res = Decode(bytes, &m);
  if (res) {
    ExpectWithinBounds(m);
    return 1;
  }
  EXPECT_FALSE(res.error.empty());
  return 0;
}

int FuzzAll(const std::vector<std::uint8_t>& bytes) {
  return FuzzDecode<msgs::Heartbeat>(bytes) + FuzzDecode<msgs::ObjectMapUpdate>(bytes) +
         FuzzDecode<msgs::KeyframePoses>(bytes) + FuzzDecode<msgs::ScanRequest>(bytes) +
         FuzzDecode<msgs::ScanReply>(bytes) + FuzzDecode<msgs::LoopClosureMessage>(bytes);
}

TEST(FleetCodec, RandomGarbageNeverCrashes) {
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> byte(0, 255), len(0, 300);
  int accepted = 0;
  for (int c = 0; c < 5000; ++c) {
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(len(rng)));
    for (auto& v : bytes) v = static_cast<std::uint8_t>(byte(rng));
    accepted += FuzzAll(bytes);
  }
  // Mutations of valid payloads reach deeper into the decoders.
  const std::vector<std::vector<std::uint8_t>> valid = {
      Encode(MakeHeartbeat()), Encode(MakeObjectUpdate()), Encode(MakePoses()),
      Encode(MakeRequest()),   Encode(MakeReply()),        Encode(MakeLoops())};
  for (int c = 0; c < 6000; ++c) {
    std::vector<std::uint8_t> bytes = valid[static_cast<std::size_t>(c) % valid.size()];
    const int flips = 1 + c % 4;
    for (int f = 0; f < flips; ++f) {
      const auto at = static_cast<std::size_t>(rng() % bytes.size());
      bytes[at] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
    }
    if (c % 7 == 0) bytes.resize(rng() % (bytes.size() + 1));
    accepted += FuzzAll(bytes);
  }
  RecordProperty("accepted", accepted);
}

// ---------------------------------------------------------------------------------------
// Deltas

msgs::ObjectMapUpdate Wire(const msgs::ObjectMapUpdate& u) {
  msgs::ObjectMapUpdate d;
  const auto res = Decode(Encode(u), &d);
  EXPECT_TRUE(res) << res.error;
  return d;
}

TEST(FleetDeltas, TwoChangedObjectsOfThirtyGiveTwoUpserts) {
  ObjectMapDeltaEncoder enc;
  msgs::ObjectMap map = Map30();
  msgs::ObjectMapUpdate full;
  full.header = Header(1);
  ASSERT_TRUE(enc.MakeUpdate(map, 0, &full));
  EXPECT_EQ(full.base_version, 0u);
  EXPECT_EQ(full.version, 1u);
  EXPECT_EQ(full.upserts.size(), 30u);
  EXPECT_EQ(full.header.incarnation, 0xdeadbeefu);  // the caller's header fields are kept

  msgs::ObjectMap held;
  std::uint32_t held_version = 0;
  ASSERT_TRUE(ApplyObjectMapUpdate(Wire(full), &held, &held_version));
  EXPECT_EQ(held_version, 1u);

  // Nothing changed beyond the thresholds: no update, *update untouched.
  msgs::ObjectMap jitter = map;
  jitter.objects[4].center.x_m += 0.05;
  msgs::ObjectMapUpdate none;
  none.version = 99;
  EXPECT_FALSE(enc.MakeUpdate(jitter, 1, &none));
  EXPECT_EQ(none.version, 99u);

  map.objects[3].center.x_m += 1.0;
  map.objects[17].length_m += 2.0;
  msgs::ObjectMapUpdate delta;
  ASSERT_TRUE(enc.MakeUpdate(map, 1, &delta));
  EXPECT_EQ(delta.base_version, 1u);
  EXPECT_EQ(delta.version, 2u);
  ASSERT_EQ(delta.upserts.size(), 2u);
  EXPECT_TRUE(delta.removed.empty());
  EXPECT_LT(Encode(delta).size() * 8, Encode(full).size() * 8 / 5);
  ASSERT_TRUE(ApplyObjectMapUpdate(Wire(delta), &held, &held_version));
  EXPECT_EQ(held_version, 2u);
  ASSERT_EQ(held.objects.size(), 30u);
  for (std::size_t i = 0; i < 30; ++i) ExpectObject(map.objects[i], held.objects[i]);

  // A removal and a new object.
  map.objects.erase(map.objects.begin() + 10);
  map.objects.push_back(Obj(500, 7, 7));
  msgs::ObjectMapUpdate d3;
  ASSERT_TRUE(enc.MakeUpdate(map, 2, &d3));
  EXPECT_EQ(d3.removed, (std::vector<std::uint32_t>{31}));
  ASSERT_EQ(d3.upserts.size(), 1u);
  EXPECT_EQ(d3.upserts[0].id, 500u);
  // Applied on the wrong base: refused, map unchanged.
  msgs::ObjectMap other = held;
  std::uint32_t other_version = 1;
  EXPECT_FALSE(ApplyObjectMapUpdate(d3, &other, &other_version));
  EXPECT_EQ(other_version, 1u);
  ASSERT_TRUE(ApplyObjectMapUpdate(Wire(d3), &held, &held_version));
  ASSERT_EQ(held.objects.size(), 30u);
  EXPECT_EQ(held.objects.back().id, 500u);
}

TEST(FleetDeltas, UnknownOrForgottenBaseGivesFull) {
  ObjectDeltaOptions o;
  o.history = 2;
  ObjectMapDeltaEncoder enc(o);
  msgs::ObjectMap map = Map30();
  msgs::ObjectMapUpdate u;
  ASSERT_TRUE(enc.MakeUpdate(map, 0, &u));
  ASSERT_TRUE(enc.MakeUpdate(map, 42, &u));  // never sent
  EXPECT_EQ(u.base_version, 0u);
  EXPECT_EQ(u.upserts.size(), 30u);
  EXPECT_EQ(u.version, 2u);
  ASSERT_TRUE(enc.MakeUpdate(map, 0, &u));
  EXPECT_EQ(enc.version(), 3u);
  ASSERT_TRUE(enc.MakeUpdate(map, 1, &u));  // version 1 forgotten (history 2)
  EXPECT_EQ(u.base_version, 0u);
  EXPECT_EQ(u.upserts.size(), 30u);
  EXPECT_FALSE(enc.MakeUpdate(map, 4, &u));  // remembered, unchanged
}

// Small changes below the threshold are remembered against what the receiver holds, so they
// are sent once they add up.
TEST(FleetDeltas, SmallChangesAddUp) {
  ObjectMapDeltaEncoder enc;
  msgs::ObjectMap map = Map30();
  msgs::ObjectMapUpdate u;
  ASSERT_TRUE(enc.MakeUpdate(map, 0, &u));
  std::uint32_t v = u.version;
  int sent = 0;
  for (int step = 0; step < 5; ++step) {
    map.objects[0].center.x_m += 0.04;
    map.objects[1].length_m += 3.0;  // always above the threshold
    ASSERT_TRUE(enc.MakeUpdate(map, v, &u));
    v = u.version;
    for (const auto& ob : u.upserts) sent += ob.id == map.objects[0].id;
  }
  EXPECT_EQ(sent, 1);  // after 3 steps (0.12 m > 0.1 m)
}

TEST(FleetDeltas, PoseDeltasSendOnlyMovedAndNewKeyframes) {
  KeyframePoseDeltaEncoder enc;
  std::vector<msgs::KeyframePoseEntry> kfs;
  for (int i = 0; i < 20; ++i) kfs.push_back({i, 1.0 * i, {1.0 * i, 0.0, 0.0}, 100});
  msgs::KeyframePoses u;
  ASSERT_TRUE(enc.MakeUpdate(kfs, false, &u));
  EXPECT_EQ(u.poses.size(), 20u);
  EXPECT_FALSE(u.full);
  EXPECT_FALSE(enc.MakeUpdate(kfs, false, &u));  // nothing moved
  kfs[3].T_map_kf.x_m += 0.5;                    // moved
  kfs[7].T_map_kf.yaw_rad += 0.05;               // turned
  kfs[9].T_map_kf.x_m += 0.05;                   // under the threshold
  kfs.push_back({20, 20.0, {20.0, 0.0, 0.0}, 90});
  ASSERT_TRUE(enc.MakeUpdate(kfs, false, &u));
  ASSERT_EQ(u.poses.size(), 3u);
  EXPECT_EQ(u.poses[0].index, 3);
  EXPECT_EQ(u.poses[1].index, 7);
  EXPECT_EQ(u.poses[2].index, 20);
  kfs[9].T_map_kf.x_m += 0.06;  // now 0.11 m from what was sent
  ASSERT_TRUE(enc.MakeUpdate(kfs, false, &u));
  ASSERT_EQ(u.poses.size(), 1u);
  EXPECT_EQ(u.poses[0].index, 9);
  ASSERT_TRUE(enc.MakeUpdate(kfs, true, &u));  // full: everything
  EXPECT_TRUE(u.full);
  EXPECT_EQ(u.poses.size(), 21u);
  msgs::KeyframePoses d;
  ASSERT_TRUE(Decode(Encode(u), &d));
  EXPECT_EQ(d.poses.size(), 21u);
}

}  // namespace
}  // namespace draco::fleet
