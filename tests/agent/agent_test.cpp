// TeamAgent (the five stages of stages.hpp chained) on a synthetic two-robot world: rectangular
// objects (outlines as points), robot A and robot B surveying it in lawnmower rows, B's map frame
// rotated and moved against A's by a known transform. The two agents exchange their outboxes
// directly (no link) step by step.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <vector>

#include "draco/agent/stages.hpp"
#include "draco/agent/team_agent.hpp"
#include "draco/registration/registration.hpp"

namespace draco::agent {
namespace {

using msgs::Point2;
using msgs::Pose2;
namespace reg = registration;
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr int kA = 0;
constexpr int kB = 1;

// Rectangle outlines on a jittered 5 x 5 grid, 22 m apart (gaps well above DBSCAN's 1.5 m),
// and small piles between them.
std::vector<Point2> World(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Point2> w;
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) {
      const double cx = 12.0 + 22.0 * i + 6.0 * (u(rng) - 0.5);
      const double cy = 12.0 + 22.0 * j + 6.0 * (u(rng) - 0.5);
      const double l = 3.0 + 7.0 * u(rng), b = 1.0 + 2.0 * u(rng), a = std::numbers::pi * u(rng);
      const double c = std::cos(a), s = std::sin(a);
      const auto add = [&](double x, double y) {
        w.push_back({cx + c * x - s * y, cy + s * x + c * y});
      };
      for (double t = -l / 2; t <= l / 2; t += 0.4) add(t, -b / 2), add(t, b / 2);
      for (double t = -b / 2 + 0.4; t < b / 2; t += 0.4) add(-l / 2, t), add(l / 2, t);
    }
  }
  // Piles: 6 points within 0.3 m, too small to be objects (d_min), structure for ICP.
  const std::size_t outlines = w.size();
  for (int pile = 0, attempt = 0; pile < 250 && attempt < 20000; ++attempt) {
    const double cx = 120.0 * u(rng), cy = 120.0 * u(rng);
    bool clear = true;
    for (std::size_t i = 0; i < outlines && clear; ++i) {
      clear = std::hypot(w[i].x_m - cx, w[i].y_m - cy) > 3.0;
    }
    if (!clear) continue;
    ++pile;
    for (int i = 0; i < 6; ++i) {
      const double a = i * std::numbers::pi / 3.0;
      w.push_back({cx + 0.15 * std::cos(a), cy + 0.15 * std::sin(a)});
    }
  }
  return w;
}

// Keyframes every 2 m along lawnmower rows at the given y, alternating direction.
std::vector<Pose2> Lawnmower(const std::vector<double>& rows, bool start_east) {
  std::vector<Pose2> out;
  bool east = !start_east;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    east = !east;
    for (double t = 0.0; t <= 120.0 + 1e-9; t += 2.0) {
      out.push_back({east ? t : 120.0 - t, rows[r], east ? 0.0 : std::numbers::pi});
    }
    if (r + 1 < rows.size()) {  // the turn: up to the next row
      const double x = east ? 120.0 : 0.0;
      for (double y = rows[r] + 2.0; y < rows[r + 1] - 1e-9; y += 2.0) {
        out.push_back({x, y, std::numbers::pi / 2});
      }
    }
  }
  return out;
}

std::vector<Point2> See(const std::vector<Point2>& world, const Pose2& T_world_kf,
                        std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 0.03);
  std::vector<Point2> out;
  const Pose2 inv = reg::Inverse(T_world_kf);
  for (const auto& p : world) {
    const Point2 q = reg::Apply(inv, p);
    const double r = std::hypot(q.x_m, q.y_m);
    if (r > 30.0 || r < 1.0 || std::abs(std::atan2(q.y_m, q.x_m)) > 65.0 * kDeg) continue;
    out.push_back({q.x_m + n(*rng), q.y_m + n(*rng)});
  }
  return out;
}

struct RobotData {
  int id = 0;
  std::uint32_t incarnation = 0;
  Pose2 T_world_map;
  std::vector<Pose2> world;  // truth per keyframe
  std::vector<msgs::Keyframe> keyframes;
};

RobotData MakeRobot(int id, const std::vector<Point2>& world, const std::vector<Pose2>& path,
                    const Pose2& T_world_map, unsigned seed) {
  RobotData r;
  r.id = id;
  r.incarnation = 100u + static_cast<std::uint32_t>(id);
  r.T_world_map = T_world_map;
  r.world = path;
  std::mt19937 rng(seed);
  const Pose2 T_map_world = reg::Inverse(T_world_map);
  for (std::size_t k = 0; k < path.size(); ++k) {
    msgs::Keyframe kf;
    kf.index = static_cast<int>(k);
    kf.time_s = static_cast<double>(k);
    kf.T_odom_body = reg::Compose(T_map_world, path[k]);
    kf.points_body = See(world, path[k], &rng);
    r.keyframes.push_back(kf);
  }
  return r;
}

AgentOptions Options(int id) {
  AgentOptions o;
  o.robot_id = id;
  o.selection.candidate_max_yaw_rad = std::numbers::pi / 2;
  o.selection.max_candidates_per_request = 3;
  return o;
}

// Checks made while the messages cross.
struct Checks {
  int requests = 0;
  int replies = 0;
  int max_request_scans = 0;
  int replies_over_bound = 0;     // replies in one outbox beyond max_scans x requests served
  int replies_not_observing = 0;  // reply keyframes that saw none of the named objects
  int loop_messages = 0;
  std::set<std::pair<int, int>> replied;  // (sender, keyframe)
  int replied_twice = 0;
};

class Exchange {
 public:
  Exchange(RobotData* a, RobotData* b) : robots_{a, b} {}

  // Delivers `out` (from robot `from`) to `to`.
  void Deliver(int from, const Outbox& out, double t, TeamAgent& to, Checks* c) {
    const RobotData& r = *robots_[from];
    msgs::FleetHeader h;
    h.robot_id = r.id;
    h.incarnation = r.incarnation;
    h.time_s = t;
    if (out.has_object_map) {
      h.seq = ++seq_[from][0];
      msgs::ObjectMap m = out.object_map;
      for (auto& o : m.objects) o.keyframes.clear();  // not sent over the link
      to.OnTeammateObjectMap(h, m);
    }
    if (!out.poses.empty()) {
      msgs::KeyframePoses p;
      p.header = h;
      p.header.seq = ++seq_[from][1];
      p.full = true;
      p.poses = out.poses;
      to.OnKeyframePoses(p);
    }
    for (auto req : out.requests) {
      ++c->requests;
      c->max_request_scans = std::max(c->max_request_scans, req.max_scans);
      req.header = h;
      pending_requests_[from] = req;
      to.OnScanRequest(req);
    }
    for (auto rep : out.replies) {
      ++c->replies;
      rep.header = h;
      if (!c->replied.insert({from, rep.keyframe}).second) ++c->replied_twice;
      to.OnScanReply(rep);
    }
    for (auto l : out.loops) {
      ++c->loop_messages;
      l.header = h;
      to.OnLoopClosures(l);
    }
  }

  // Robot `from`'s shared map-to-map estimates (the heartbeat's transforms) to `to`.
  void ShareTransforms(int from, const TeamAgent& from_agent, double t, TeamAgent& to) {
    msgs::TeammateTransforms m;
    m.header.robot_id = robots_[from]->id;
    m.header.incarnation = robots_[from]->incarnation;
    m.header.time_s = t;
    m.header.seq = ++seq_[from][2];
    m.transforms = from_agent.SharedTransforms();
    to.OnTeammateTransforms(m);
  }

  // Replies in `out` of robot `from` answer the request its teammate sent last.
  void CheckReplies(int from, const Outbox& out, const TeamAgent& agent, int max_scans,
                    int requests_served, Checks* c) {
    if (static_cast<int>(out.replies.size()) > max_scans * requests_served) {
      ++c->replies_over_bound;
    }
    if (out.replies.empty()) return;
    const auto it = pending_requests_.find(1 - from);
    ASSERT_NE(it, pending_requests_.end());
    const std::set<std::uint32_t> named(it->second.object_ids.begin(), it->second.object_ids.end());
    const auto own = agent.OwnObjects();
    for (const auto& rep : out.replies) {
      bool saw = false;
      for (const auto& o : own.objects) {
        if (!named.count(o.id)) continue;
        for (const int k : o.keyframes) saw = saw || k == rep.keyframe;
      }
      if (!saw) ++c->replies_not_observing;
    }
  }

 private:
  RobotData* robots_[2];
  std::map<int, std::array<std::uint32_t, 3>> seq_;
  std::map<int, msgs::ScanRequest> pending_requests_;
};

struct Mission {
  RobotData a, b;
  std::unique_ptr<TeamAgent> agent_a, agent_b;
  Checks checks;
  double end_s = 0.0;
};

// Both robots' keyframes up to t given to their agents; both step; outboxes swapped.
void Simulate(Mission* run) {
  const auto world = World(7);
  const Pose2 T_world_b{40.0, -25.0, 30.0 * kDeg};
  run->a = MakeRobot(kA, world, Lawnmower({10.0, 40.0, 70.0, 100.0}, true), {}, 1);
  run->b = MakeRobot(kB, world, Lawnmower({25.0, 55.0, 85.0}, false), T_world_b, 2);
  run->agent_a = std::make_unique<TeamAgent>(Options(kA));
  run->agent_b = std::make_unique<TeamAgent>(Options(kB));
  RobotData* robots[2] = {&run->a, &run->b};
  TeamAgent* agents[2] = {run->agent_a.get(), run->agent_b.get()};
  Exchange ex(&run->a, &run->b);
  const double last =
      static_cast<double>(std::max(run->a.keyframes.size(), run->b.keyframes.size()));
  std::size_t next[2] = {0, 0};
  int requests_in[2] = {0, 0};  // requests delivered to robot i before its step
  for (double t = 5.0; t <= last + 30.0; t += 5.0) {
    Outbox out[2];
    for (int i = 0; i < 2; ++i) {
      RobotData& r = *robots[i];
      bool any = false;
      while (next[i] < r.keyframes.size() && r.keyframes[next[i]].time_s <= t) {
        agents[i]->OnKeyframe(r.keyframes[next[i]]);
        ++next[i];
        any = true;
      }
      if (any) {
        msgs::KeyframeTrajectory traj;
        traj.time_s = r.keyframes[next[i] - 1].time_s;
        for (std::size_t k = 0; k < next[i]; ++k) {
          traj.keyframes.push_back(
              {static_cast<int>(k), r.keyframes[k].time_s, r.keyframes[k].T_odom_body});
        }
        agents[i]->OnTrajectory(traj);
      }
      out[i] = agents[i]->Step(t);
      ex.CheckReplies(i, out[i], *agents[i], Options(i).max_scans_per_request, requests_in[i],
                      &run->checks);
    }
    for (int i = 0; i < 2; ++i) {
      requests_in[1 - i] = static_cast<int>(out[i].requests.size());
      ex.Deliver(i, out[i], t, *agents[1 - i], &run->checks);
      ex.ShareTransforms(i, *agents[i], t, *agents[1 - i]);
    }
    run->end_s = t;
  }
}

double Deg(double rad) { return std::abs(reg::WrapAngle(rad)) / kDeg; }

class AgentTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    run_ = new Mission;
    Simulate(run_);
  }
  static void TearDownTestSuite() {
    delete run_;
    run_ = nullptr;
  }
  static Mission* run_;
};
Mission* AgentTest::run_ = nullptr;

TEST_F(AgentTest, MatchesTeammateMap) {
  const Pose2 truth = reg::Between(run_->a.T_world_map, run_->b.T_world_map);
  for (int own = 0; own < 2; ++own) {
    const TeamAgent& agent = own == 0 ? *run_->agent_a : *run_->agent_b;
    const Pose2 T_true = own == 0 ? truth : reg::Inverse(truth);
    const auto& mates = agent.teammates();
    ASSERT_EQ(mates.count(1 - own), 1u);
    const auto& m = mates.at(1 - own);
    ASSERT_TRUE(m.matched) << "robot " << own;
    const Pose2 e = reg::Between(T_true, m.last_match.T_a_b);
    EXPECT_LT(std::hypot(e.x_m, e.y_m), 0.5) << "robot " << own;
    EXPECT_LT(Deg(e.yaw_rad), 2.0) << "robot " << own;
    EXPECT_GT(m.scans_received, 0);
    EXPECT_EQ(m.ignored, 0);
    std::printf(
        "robot %d: match error %.3f m %.3f deg, %d inliers, %d scans, %d candidates, "
        "%d accepted\n",
        own, std::hypot(e.x_m, e.y_m), Deg(e.yaw_rad), m.last_match.num_inliers, m.scans_received,
        m.candidates, m.accepted);
  }
}

TEST_F(AgentTest, RequestsAndRepliesAreBounded) {
  const Checks& c = run_->checks;
  EXPECT_GT(c.requests, 0);
  EXPECT_GT(c.replies, 0);
  EXPECT_LE(c.max_request_scans, Options(0).max_scans_per_request);
  EXPECT_EQ(c.replies_over_bound, 0);
  EXPECT_EQ(c.replies_not_observing, 0);
  EXPECT_EQ(c.replied_twice, 0);  // each keyframe at most once per requester
  EXPECT_GT(c.loop_messages, 0);
  std::printf("requests %d, replies %d, loop messages %d\n", c.requests, c.replies,
              c.loop_messages);
}

TEST_F(AgentTest, AcceptedLoopsAreTrue) {
  for (int own = 0; own < 2; ++own) {
    const TeamAgent& agent = own == 0 ? *run_->agent_a : *run_->agent_b;
    const RobotData& me = own == 0 ? run_->a : run_->b;
    const RobotData& mate = own == 0 ? run_->b : run_->a;
    const auto& est = agent.estimate();
    EXPECT_GE(est.accepted.size(), 5u) << "robot " << own;
    std::set<std::uint64_t> ids;
    std::set<std::tuple<int, int, int>> pairs;
    double worst = 0.0;
    for (const auto& l : est.accepted) {
      EXPECT_EQ(l.own_robot, own);
      EXPECT_TRUE(ids.insert(l.id).second) << "duplicate id";
      EXPECT_TRUE(pairs.insert({l.teammate_robot, l.own_keyframe, l.teammate_keyframe}).second)
          << "duplicate keyframe pair";
      const Pose2 truth = reg::Between(me.world[static_cast<std::size_t>(l.own_keyframe)],
                                       mate.world[static_cast<std::size_t>(l.teammate_keyframe)]);
      const Pose2 e = reg::Between(truth, l.T_ownkf_teammatekf);
      worst = std::max(worst, std::hypot(e.x_m, e.y_m));
      EXPECT_LT(std::hypot(e.x_m, e.y_m), 0.3)
          << "loop " << l.id << " own " << l.own_keyframe << " team " << l.teammate_keyframe
          << " ov " << l.overlap << " err " << e.x_m << "," << e.y_m << "," << e.yaw_rad / kDeg
          << " cov " << l.covariance[0] << "," << l.covariance[4] << "," << l.covariance[8];
      EXPECT_LT(Deg(e.yaw_rad), 2.0) << "loop " << l.id;
    }
    std::printf("robot %d: %zu candidates, %zu accepted, worst accepted error %.3f m\n", own,
                est.candidates.size(), est.accepted.size(), worst);
  }
}

TEST_F(AgentTest, EstimatePlacesTeammateTrajectory) {
  for (int own = 0; own < 2; ++own) {
    const TeamAgent& agent = own == 0 ? *run_->agent_a : *run_->agent_b;
    const RobotData& me = own == 0 ? run_->a : run_->b;
    const RobotData& mate = own == 0 ? run_->b : run_->a;
    const auto& est = agent.estimate();
    ASSERT_EQ(est.trajectories.count(1 - own), 1u);
    ASSERT_EQ(est.trajectories.count(own), 1u);
    const auto& traj = est.trajectories.at(1 - own);
    EXPECT_EQ(traj.size(), mate.keyframes.size());
    const Pose2 T_own_world = reg::Inverse(me.T_world_map);
    double sum = 0.0, worst = 0.0;
    for (const auto& p : traj) {
      const Pose2 truth = reg::Compose(T_own_world, mate.world[static_cast<std::size_t>(p.index)]);
      const double e = std::hypot(p.T_map_kf.x_m - truth.x_m, p.T_map_kf.y_m - truth.y_m);
      sum += e;
      worst = std::max(worst, e);
    }
    const double mean = sum / static_cast<double>(traj.size());
    EXPECT_LT(mean, 0.3) << "robot " << own;
    EXPECT_LT(worst, 1.0) << "robot " << own;
    ASSERT_EQ(est.T_own_teammate.count(1 - own), 1u);
    const Pose2 T_true = reg::Between(me.T_world_map, mate.T_world_map);
    const Pose2 e = reg::Between(T_true, est.T_own_teammate.at(1 - own));
    EXPECT_LT(std::hypot(e.x_m, e.y_m), 0.5);
    EXPECT_LT(Deg(e.yaw_rad), 1.0);
    int optimized = 0;
    double wall_max = 0.0, wall_sum = 0.0;
    for (const auto& s : agent.step_stats()) {
      optimized += s.optimized ? 1 : 0;
      wall_max = std::max(wall_max, s.wall_ms);
      wall_sum += s.wall_ms;
    }
    std::printf("robot %d: step wall time max %.1f ms, total %.1f ms\n", own, wall_max, wall_sum);
    EXPECT_GT(optimized, 0);
    std::printf(
        "robot %d: teammate trajectory error mean %.3f m max %.3f m; map-to-map %.3f m "
        "%.3f deg; %d optimisations over %zu steps\n",
        own, mean, worst, std::hypot(e.x_m, e.y_m), Deg(e.yaw_rad), optimized,
        agent.step_stats().size());
  }
}

bool SameBits(double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; }

TEST_F(AgentTest, SecondRunIsBitIdentical) {
  Mission again;
  Simulate(&again);
  for (int own = 0; own < 2; ++own) {
    const auto& e1 = (own == 0 ? run_->agent_a : run_->agent_b)->estimate();
    const auto& e2 = (own == 0 ? again.agent_a : again.agent_b)->estimate();
    ASSERT_EQ(e1.trajectories.size(), e2.trajectories.size());
    for (const auto& [robot, t1] : e1.trajectories) {
      const auto& t2 = e2.trajectories.at(robot);
      ASSERT_EQ(t1.size(), t2.size());
      for (std::size_t k = 0; k < t1.size(); ++k) {
        EXPECT_EQ(t1[k].index, t2[k].index);
        EXPECT_TRUE(SameBits(t1[k].T_map_kf.x_m, t2[k].T_map_kf.x_m));
        EXPECT_TRUE(SameBits(t1[k].T_map_kf.y_m, t2[k].T_map_kf.y_m));
        EXPECT_TRUE(SameBits(t1[k].T_map_kf.yaw_rad, t2[k].T_map_kf.yaw_rad));
      }
    }
    ASSERT_EQ(e1.candidates.size(), e2.candidates.size());
    for (std::size_t i = 0; i < e1.candidates.size(); ++i) {
      EXPECT_EQ(e1.candidates[i].id, e2.candidates[i].id);
      EXPECT_EQ(e1.candidates[i].flags, e2.candidates[i].flags);
      EXPECT_TRUE(SameBits(e1.candidates[i].T_ownkf_teammatekf.x_m,
                           e2.candidates[i].T_ownkf_teammatekf.x_m));
    }
    const auto& s1 = (own == 0 ? run_->agent_a : run_->agent_b)->step_stats();
    const auto& s2 = (own == 0 ? again.agent_a : again.agent_b)->step_stats();
    ASSERT_EQ(s1.size(), s2.size());
    for (std::size_t i = 0; i < s1.size(); ++i) {
      EXPECT_EQ(s1[i].matches_found, s2[i].matches_found);
      EXPECT_EQ(s1[i].candidates_added, s2[i].candidates_added);
      EXPECT_EQ(s1[i].loops_accepted, s2[i].loops_accepted);
      EXPECT_EQ(s1[i].optimized, s2[i].optimized);
    }
  }
}

// Scenario-independent checks on a fresh pair (the suite's run stays untouched).
TEST(AgentMessages, UnknownKeyframesAreIgnored) {
  Mission run;
  Simulate(&run);
  TeamAgent& a = *run.agent_a;
  const int ignored0 = a.teammates().at(kB).ignored;
  const std::size_t candidates0 = a.estimate().candidates.size();
  msgs::FleetHeader h;
  h.robot_id = kB;
  h.incarnation = run.b.incarnation;
  // Beyond max_teammate_keyframes: dropped on arrival.
  msgs::ScanReply far;
  far.header = h;
  far.requester_robot = kA;
  far.keyframe = 1 << 30;
  far.points_kf = run.b.keyframes[10].points_body;
  a.OnScanReply(far);
  EXPECT_EQ(a.teammates().at(kB).ignored, ignored0 + 1);
  // In range but never shared by the teammate: dropped at the step, no registration.
  msgs::ScanReply unknown = far;
  unknown.keyframe = 15000;
  a.OnScanReply(unknown);
  // A reply meant for another robot: not ours, not counted.
  msgs::ScanReply other = far;
  other.requester_robot = 5;
  other.keyframe = 3;
  a.OnScanReply(other);
  // Loops naming keyframes A does not have (either side), and a broken covariance.
  msgs::LoopClosureMessage lm;
  lm.header = h;
  lm.target_robot = kA;
  msgs::InterRobotLoop l;
  l.own_robot = kB;
  l.teammate_robot = kA;
  l.own_keyframe = 10;
  l.teammate_keyframe = 99999;  // A's keyframe: unknown
  l.covariance = {0.01, 0, 0, 0, 0.01, 0, 0, 0, 1e-4};
  lm.loops.push_back(l);
  l.own_keyframe = 19999;  // B's keyframe: never shared
  l.teammate_keyframe = 10;
  lm.loops.push_back(l);
  l.own_keyframe = 10;
  l.covariance = {-1, 0, 0, 0, 0.01, 0, 0, 0, 1e-4};  // not positive definite
  lm.loops.push_back(l);
  a.OnLoopClosures(lm);
  a.Step(run.end_s + 5.0);
  EXPECT_EQ(a.teammates().at(kB).ignored, ignored0 + 5);
  EXPECT_EQ(a.step_stats().back().candidates_added, 0);
  EXPECT_EQ(a.estimate().candidates.size(), candidates0);

  // Wrong loops on known keyframes (a correlated group, all 3 m off): filtered out by GCM.
  msgs::LoopClosureMessage wrong;
  wrong.header = h;
  wrong.target_robot = kA;
  for (int i = 0; i < 8; ++i) {
    msgs::InterRobotLoop w;
    w.own_robot = kB;
    w.own_keyframe = 20 + 3 * i;  // B's keyframe
    w.teammate_robot = kA;
    w.teammate_keyframe = 100 + 3 * i;  // A's keyframe
    const Pose2 truth = reg::Between(run.b.world[static_cast<std::size_t>(w.own_keyframe)],
                                     run.a.world[static_cast<std::size_t>(w.teammate_keyframe)]);
    w.T_ownkf_teammatekf = reg::Compose(Pose2{3.0, 0.0, 0.0}, truth);
    w.covariance = {0.01, 0, 0, 0, 0.01, 0, 0, 0, 1e-4};
    wrong.loops.push_back(w);
  }
  a.OnLoopClosures(wrong);
  a.Step(run.end_s + 10.0);
  EXPECT_EQ(a.step_stats().back().candidates_added, 8);
  EXPECT_EQ(a.estimate().candidates.size(), candidates0 + 8);
  for (const auto& acc : a.estimate().accepted) {
    EXPECT_FALSE(acc.own_keyframe >= 100 && acc.own_keyframe < 124 && acc.teammate_keyframe >= 20 &&
                 acc.teammate_keyframe < 44 && (acc.own_keyframe - 100) % 3 == 0 &&
                 (acc.own_keyframe - 100) / 3 == (acc.teammate_keyframe - 20) / 3 &&
                 (acc.teammate_keyframe - 20) % 3 == 0)
        << "wrong loop accepted: " << acc.own_keyframe << " " << acc.teammate_keyframe;
  }
}

TEST(AgentMessages, ServesRequestsOncePerKeyframe) {
  Mission run;
  Simulate(&run);
  TeamAgent& b = *run.agent_b;
  const auto own = b.OwnObjects();
  ASSERT_GE(own.objects.size(), 3u);
  // A request from a third robot (a new teammate) for three of B's objects.
  msgs::ScanRequest req;
  req.header.robot_id = 7;
  req.header.incarnation = 1;
  req.target_robot = kB;
  req.max_scans = 4;
  std::set<int> observed;
  for (int i = 0; i < 3; ++i) {
    req.object_ids.push_back(own.objects[static_cast<std::size_t>(i)].id);
    observed.insert(own.objects[static_cast<std::size_t>(i)].keyframes.begin(),
                    own.objects[static_cast<std::size_t>(i)].keyframes.end());
  }
  req.object_ids.push_back(123456);  // unknown id: nothing
  b.OnScanRequest(req);
  auto out = b.Step(run.end_s + 5.0);
  ASSERT_EQ(out.replies.size(), 4u);
  std::set<int> sent;
  for (const auto& r : out.replies) {
    EXPECT_EQ(r.requester_robot, 7);
    EXPECT_TRUE(observed.count(r.keyframe)) << r.keyframe;
    EXPECT_GE(r.points_kf.size(), 30u);
    sent.insert(r.keyframe);
  }
  // The same request again: other keyframes, never the ones already sent.
  b.OnScanRequest(req);
  out = b.Step(run.end_s + 10.0);
  for (const auto& r : out.replies) EXPECT_FALSE(sent.count(r.keyframe)) << r.keyframe;
  // A restart of robot 7 (new incarnation) forgets what was sent to it.
  req.header.incarnation = 2;
  b.OnScanRequest(req);
  out = b.Step(run.end_s + 15.0);
  ASSERT_EQ(out.replies.size(), 4u);
  std::set<int> again;
  for (const auto& r : out.replies) again.insert(r.keyframe);
  EXPECT_EQ(again, sent);
}

TEST(AgentMessages, ForgetAndNewIncarnationClearTeammate) {
  Mission run;
  Simulate(&run);
  TeamAgent& a = *run.agent_a;
  ASSERT_TRUE(a.teammates().at(kB).matched);
  ASSERT_FALSE(a.estimate().accepted.empty());
  // New incarnation of B: everything held of it is dropped, then re-learnt from the message.
  msgs::FleetHeader h;
  h.robot_id = kB;
  h.incarnation = run.b.incarnation + 1;
  msgs::ObjectMap empty_map;
  a.OnTeammateObjectMap(h, empty_map);
  ASSERT_EQ(a.teammates().count(kB), 1u);
  const auto& s = a.teammates().at(kB);
  EXPECT_EQ(s.incarnation, run.b.incarnation + 1);
  EXPECT_FALSE(s.matched);
  EXPECT_TRUE(s.keyframes.empty());
  EXPECT_EQ(s.scans_received, 0);
  EXPECT_EQ(s.candidates, 0);
  EXPECT_TRUE(a.estimate().candidates.empty());
  EXPECT_TRUE(a.estimate().accepted.empty());
  a.Step(run.end_s + 5.0);
  EXPECT_EQ(a.estimate().trajectories.count(kB), 0u);
  EXPECT_EQ(a.estimate().trajectories.count(kA), 1u);
  // Forget: gone entirely.
  a.ForgetTeammate(kB);
  EXPECT_EQ(a.teammates().count(kB), 0u);
  a.Step(run.end_s + 10.0);
  EXPECT_EQ(a.estimate().trajectories.count(kB), 0u);
  EXPECT_EQ(a.estimate().T_own_teammate.count(kB), 0u);
  // Own trajectory back to the local one (no loops left).
  const auto& own = a.estimate().trajectories.at(kA);
  ASSERT_EQ(own.size(), run.a.keyframes.size());
  for (std::size_t k = 0; k < own.size(); ++k) {
    EXPECT_EQ(own[k].T_map_kf.x_m, run.a.keyframes[k].T_odom_body.x_m);
  }
}

// ---------------------------------------------------------------------- the stages alone

TEST(ObjectMapperStage, PublishesAtMostEveryPeriodWhenChanged) {
  const auto world = World(7);
  const RobotData r = MakeRobot(kA, world, Lawnmower({10.0, 40.0}, true), {}, 1);
  ObjectMapperStageOptions o;
  o.robot_id = kA;
  o.object_map_period_s = 10.0;
  ObjectMapperStage stage(o);
  double last_sent = -1e9;
  int sent = 0, poses_sent = 0;
  std::uint64_t version = 0;
  std::size_t next = 0;
  for (int t = 1; t <= 140; ++t) {
    bool any = false;
    while (next < r.keyframes.size() && r.keyframes[next].time_s <= t) {
      stage.OnKeyframe(r.keyframes[next++]);
      any = true;
    }
    if (any && t <= 100) {  // no new keyframes or poses after 100 s
      msgs::KeyframeTrajectory traj;
      for (std::size_t k = 0; k < next; ++k) {
        traj.keyframes.push_back(
            {static_cast<int>(k), r.keyframes[k].time_s, r.keyframes[k].T_odom_body});
      }
      stage.OnTrajectory(traj);
    }
    msgs::TeamStepStats st;
    const auto out = stage.Step(t, &st);
    EXPECT_EQ(st.time_s, t);
    EXPECT_GE(stage.version(), version);
    if (out.has_object_map) {
      EXPECT_GE(t - last_sent, o.object_map_period_s) << t;
      EXPECT_EQ(out.object_map.robot_id, kA);
      EXPECT_FALSE(out.object_map.objects.empty());
      last_sent = t;
      ++sent;
    }
    if (out.has_poses) {
      ++poses_sent;
      EXPECT_LE(t, 100);                  // only when a pose changed
      EXPECT_EQ(out.poses.size(), next);  // every own keyframe, current pose
    }
    version = stage.version();
  }
  EXPECT_GE(sent, 3);
  EXPECT_GT(poses_sent, 10);
  EXPECT_LE(stage.version(), 100u);  // changes only while keyframes came
}

// map_heading_from_keyframes: the AHRS heading of each keyframe (the odom frame's heading plus
// the dead-reckoned yaw) minus the local SLAM's yaw, averaged on the circle. The local SLAM
// turned the map by -0.04 rad against the odom frame (+-0.01 rad from keyframe to keyframe):
// the map's heading is the odom heading + 0.04. Off: the odom frame's heading, the first AHRS
// reading.
TEST(ObjectMapperStage, MapHeadingIsTheMeanOfAhrsMinusSlamYaw) {
  const auto world = World(7);
  const RobotData r = MakeRobot(kA, world, Lawnmower({10.0, 40.0}, true), {}, 1);
  for (const bool mean : {false, true}) {
    ObjectMapperStageOptions o;
    o.robot_id = kA;
    o.object_map_period_s = 1.0;
    o.map_heading_from_keyframes = mean;
    ObjectMapperStage stage(o);
    msgs::KeyframeTrajectory traj;
    const double heading = 3.1;  // near +-pi: the mean must wrap
    for (std::size_t k = 0; k < 40 && k < r.keyframes.size(); ++k) {
      msgs::Keyframe kf = r.keyframes[k];
      kf.odom_heading_rad = heading;
      stage.OnKeyframe(kf);
      Pose2 T = kf.T_odom_body;
      T.yaw_rad -= 0.04 + (k % 2 == 0 ? 0.01 : -0.01);
      traj.keyframes.push_back({static_cast<int>(k), kf.time_s, T});
    }
    stage.OnTrajectory(traj);
    const auto out = stage.Step(100.0, nullptr);
    ASSERT_TRUE(out.has_object_map);
    const double want = mean ? std::remainder(heading + 0.04, 2.0 * M_PI) : heading;
    EXPECT_NEAR(std::remainder(out.object_map.map_heading_rad - want, 2.0 * M_PI), 0.0, 1e-9)
        << mean;
  }
}

TEST(ObjectMapperStage, AppendsTheLocalSlamLandmarksSeenOften) {
  const auto world = World(7);
  const RobotData r = MakeRobot(kA, world, Lawnmower({10.0, 40.0}, true), {}, 1);
  ObjectMapperStageOptions o;
  o.robot_id = kA;
  o.object_map_period_s = 1.0;
  ObjectMapperStage stage(o);
  msgs::KeyframeTrajectory traj;
  for (std::size_t k = 0; k < 10 && k < r.keyframes.size(); ++k) {
    stage.OnKeyframe(r.keyframes[k]);
    traj.keyframes.push_back(
        {static_cast<int>(k), r.keyframes[k].time_s, r.keyframes[k].T_odom_body});
  }
  // Landmark 4 seen from keyframes 1, 3, 5 (most), 9 from 2, 7 (enough), 12 once (too few),
  // 13 only from keyframe 20 (not mapped yet).
  traj.landmarks = {{9, {3.0, -1.0}, 0.4, {2, 7}},
                    {4, {12.0, 5.0}, 0.8, {1, 3, 5}},
                    {12, {1.0, 1.0}, 0.5, {6}},
                    {13, {2.0, 2.0}, 0.5, {20, 21}}};
  stage.OnTrajectory(traj);
  const auto out = stage.Step(20.0, nullptr);
  ASSERT_TRUE(out.has_object_map);
  std::vector<const msgs::Object*> landmarks;
  for (const auto& ob : out.object_map.objects) {
    EXPECT_EQ(ob.landmark, (ob.id & msgs::kLandmarkIdBit) != 0) << ob.id;
    if (ob.landmark) landmarks.push_back(&ob);
  }
  ASSERT_EQ(landmarks.size(), 2u);
  EXPECT_EQ(landmarks[0]->id, msgs::kLandmarkIdBit + 4);  // most seen first
  EXPECT_EQ(landmarks[0]->keyframes, (std::vector<int>{1, 3, 5}));
  EXPECT_DOUBLE_EQ(landmarks[0]->length_m, 1.6);
  EXPECT_DOUBLE_EQ(landmarks[0]->center.x_m, 12.0);
  EXPECT_EQ(landmarks[1]->id, msgs::kLandmarkIdBit + 9);
  EXPECT_GT(out.object_map.objects.size(), landmarks.size());  // the clusters are still there
}

// The own robot of an OptimizerStage test: n keyframes 2 m apart along x, one point each.
msgs::KeyframeTrajectory OwnStraightLine(OptimizerStage* stage, int n) {
  msgs::KeyframeTrajectory traj;
  for (int k = 0; k < n; ++k) {
    msgs::Keyframe kf;
    kf.index = k;
    kf.time_s = k;
    kf.T_odom_body = {2.0 * k, 0.0, 0.0};
    kf.points_body = {{1.0, 0.0}};
    stage->OnKeyframe(kf);
    traj.keyframes.push_back({k, double(k), kf.T_odom_body});
  }
  stage->OnTrajectory(traj);
  return traj;
}

TEST(OptimizerStage, PlacesARobotThroughATeammatesSharedTransform) {
  // Own robot 0 has an accepted loop with robot 1 and no match with robot 2; robot 1 shares
  // its loop-verified T_1_2. Robot 2 is placed at T_0_1 * T_1_2 and counts as verified.
  OptimizerStageOptions o;
  o.mutual_placement_max_gap_m = 0.0;  // other rules under test
  o.robot_id = 0;
  o.optimize_period_s = 0.0;
  o.min_teammate_loops = 1;  // one loop verifies here (the evidence gate has its own test)
  o.min_distinct_keyframes = 1;
  o.place_chained_teammates = true;  // the chained placement under test
  OptimizerStage stage(o);
  const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 5);
  for (int robot : {1, 2}) {
    msgs::KeyframePoses p;
    p.header.robot_id = robot;
    p.header.incarnation = 1;
    p.full = true;
    for (int k = 0; k < 5; ++k) p.poses.push_back({k, double(k), {0.0, 2.0 * k, 0.5}, 10});
    stage.OnKeyframePoses(p);
  }
  const Pose2 T_0_1{5.0, 1.0, 0.3}, T_1_2{-3.0, 4.0, -0.7};
  msgs::MapMatches matches;
  auto& g = matches.guesses[1];
  g.robot_id = 1;
  g.matched = true;
  g.match.T_a_b = T_0_1;
  g.match_count = 1;
  msgs::InterRobotLoop loop;
  loop.id = 1;
  loop.own_robot = 0;
  loop.own_keyframe = 2;
  loop.teammate_robot = 1;
  loop.teammate_keyframe = 2;
  loop.T_ownkf_teammatekf =
      reg::Between(traj.keyframes[2].T_map_kf, reg::Compose(T_0_1, Pose2{0.0, 4.0, 0.5}));
  loop.covariance = {0.01, 0, 0, 0, 0.01, 0, 0, 0, 1e-4};
  loop.flags = msgs::kLoopAccepted;
  msgs::TeamStepStats st;
  stage.Step(10.0, {loop}, matches, &st);
  EXPECT_EQ(stage.estimate().trajectories.count(2), 0u);  // nothing places robot 2 yet
  ASSERT_EQ(stage.SharedTransforms().size(), 1u);         // own verified estimate of robot 1
  EXPECT_EQ(stage.SharedTransforms()[0].robot_id, 1);
  msgs::TeammateTransforms shared;
  shared.header.robot_id = 1;
  shared.header.incarnation = 1;
  shared.transforms = {{2, T_1_2}, {0, {}}};  // an entry about ourselves is ignored
  stage.OnTeammateTransforms(shared);
  stage.Step(20.0, {loop}, matches, &st);
  ASSERT_EQ(stage.estimate().trajectories.count(2), 1u);
  const auto& t2 = stage.estimate().trajectories.at(2);
  ASSERT_EQ(t2.size(), 5u);
  const Pose2 T_0_1_est = stage.estimate().T_own_teammate.at(1);
  const Pose2 want = reg::Compose(reg::Compose(T_0_1_est, T_1_2), Pose2{0.0, 6.0, 0.5});
  EXPECT_NEAR(t2[3].T_map_kf.x_m, want.x_m, 1e-6);
  EXPECT_NEAR(t2[3].T_map_kf.y_m, want.y_m, 1e-6);
  // Robot 2 is not shared on (only loop-verified estimates are).
  for (const auto& e : stage.SharedTransforms()) EXPECT_NE(e.robot_id, 2);
  // Robot 1 restarts: what it shared is forgotten, robot 2 is no longer placed.
  stage.Forget(1);
  stage.Step(30.0, {}, msgs::MapMatches{}, &st);
  EXPECT_EQ(stage.estimate().trajectories.count(2), 0u);
}

// Robot 0's optimiser, a PGO every step, mutual placement off (the tests of other rules).
OptimizerStageOptions OtherRulesOptions() {
  OptimizerStageOptions o;
  o.mutual_placement_max_gap_m = 0.0;
  o.robot_id = 0;
  o.optimize_period_s = 0.0;
  return o;
}

// Teammate 1: eight keyframes along its map's y axis, matched at T_0_1; Loop() gives the
// loop between an own keyframe and one of its as the truth has it, accepted.
struct TeammateOne {
  Pose2 T_0_1{5.0, 1.0, 0.3};
  msgs::KeyframePoses poses;
  msgs::MapMatches matches;
  explicit TeammateOne(OptimizerStage* stage) {
    poses.header.robot_id = 1;
    poses.header.incarnation = 1;
    poses.full = true;
    for (int k = 0; k < 8; ++k) poses.poses.push_back({k, double(k), {0.0, 2.0 * k, 0.5}, 10});
    if (stage != nullptr) stage->OnKeyframePoses(poses);
    auto& g = matches.guesses[1];
    g.robot_id = 1;
    g.matched = true;
    g.match.T_a_b = T_0_1;
    g.match_count = 1;
  }
  msgs::InterRobotLoop Loop(const msgs::KeyframeTrajectory& own, std::uint64_t id, int own_k,
                            int mate_k) const {
    msgs::InterRobotLoop l;
    l.id = id;
    l.own_robot = 0;
    l.own_keyframe = own_k;
    l.teammate_robot = 1;
    l.teammate_keyframe = mate_k;
    l.T_ownkf_teammatekf = reg::Between(own.keyframes[own_k].T_map_kf,
                                        reg::Compose(T_0_1, poses.poses[mate_k].T_map_kf));
    l.covariance = {0.01, 0, 0, 0, 0.01, 0, 0, 0, 1e-4};
    l.flags = msgs::kLoopAccepted;
    return l;
  }
  // Loop() for each (own keyframe, teammate keyframe), ids first_id, first_id + 1, ...
  std::vector<msgs::InterRobotLoop> Loops(const msgs::KeyframeTrajectory& own,
                                          std::uint64_t first_id,
                                          const std::vector<std::pair<int, int>>& pairs) const {
    std::vector<msgs::InterRobotLoop> out;
    for (std::size_t i = 0; i < pairs.size(); ++i)
      out.push_back(Loop(own, first_id + i, pairs[i].first, pairs[i].second));
    return out;
  }
};

// Teammate 1 placed by loops (own keyframe, teammate keyframe) at T_0_1 (yaw 0.3), the maps'
// absolute headings saying the rotation is 0.4; nullopt when it is not placed.
// lever_m (optional): the step's rotation lever for it, -1 when not computed.
std::optional<Pose2> PlaceWithHeadings(OptimizerStageOptions o,
                                       const std::vector<std::pair<int, int>>& pairs, Pose2* T_0_1,
                                       double* lever_m = nullptr, std::string* held = nullptr) {
  o.robot_id = 0;
  o.optimize_period_s = 0.0;
  OptimizerStage stage(o);
  const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
  const TeammateOne mate(&stage);
  *T_0_1 = mate.T_0_1;
  msgs::ObjectMap own_map, mate_map;
  own_map.map_heading_rad = 1.0;
  mate_map.map_heading_rad = 1.4;
  stage.OnOwnObjectMap(own_map);
  msgs::FleetHeader header;
  header.robot_id = 1;
  header.incarnation = 1;
  stage.OnTeammateObjectMap(header, mate_map);
  const std::vector<msgs::InterRobotLoop> loops = mate.Loops(traj, 11, pairs);
  msgs::TeamStepStats st;
  stage.Step(20.0, loops, mate.matches, &st);
  if (lever_m != nullptr) {
    const auto& levers = stage.estimate().rotation_lever_m;
    *lever_m = levers.count(1) ? levers.at(1) : -1.0;
  }
  if (held != nullptr) {
    const auto& h = stage.estimate().held;
    *held = h.count(1) ? h.at(1) : "";
  }
  if (!stage.estimate().trajectories.count(1)) return std::nullopt;
  return stage.estimate().T_own_teammate.at(1);
}

// placement_heading_weight: half way toward the headings, yaw 0.35, turned about the centroid
// of the teammate keyframes the loops name, which stays where the loops put it.
TEST(OptimizerStage, TurnsAPlacedTeammateHalfWayTowardTheHeadings) {
  for (const double weight : {0.0, 0.5}) {
    OptimizerStageOptions o;
    o.mutual_placement_max_gap_m = 0.0;  // other rules under test
    o.placement_heading_weight = weight;
    o.placement_heading_variance_ratio = 0.0;  // weight 0: no turn at all
    Pose2 T_0_1;
    const auto T = PlaceWithHeadings(o, {{1, 2}, {3, 4}, {5, 6}, {1, 4}, {3, 6}}, &T_0_1);
    ASSERT_TRUE(T.has_value());
    EXPECT_NEAR(T->yaw_rad, T_0_1.yaw_rad + weight * 0.1, 1e-4) << weight;
    // The loops' teammate keyframes 2, 4, 6, 4, 6: centroid (0, 8.8) in the teammate's map.
    const Pose2 centroid{0.0, 8.8, 0.0};
    const Pose2 a = reg::Compose(*T, centroid), b = reg::Compose(T_0_1, centroid);
    EXPECT_NEAR(a.x_m, b.x_m, 1e-3) << weight;
    EXPECT_NEAR(a.y_m, b.y_m, 1e-3) << weight;
  }
}

// placement_heading_variance_ratio: the turn's fraction is u / (u + ratio), u the parts of
// the two missions (keyframe times 0-7 s each) that the loops' keyframes do not span. Loops
// over own keyframes 1-5 and teammate keyframes 2-6 leave 3/7 of each: u = 6/7, with ratio 2
// the fraction is 0.3 and the yaw 0.3 + 0.3 * 0.1. Loops from the first keyframes to the
// last span both missions: no turn.
TEST(OptimizerStage, TurnsAPlacedTeammateTowardTheHeadingsAsFarAsItsLoopsLeaveTheMissions) {
  const std::vector<std::pair<int, int>> partial{{1, 2}, {3, 4}, {5, 6}, {1, 4}, {3, 6}};
  const std::vector<std::pair<int, int>> whole{{0, 0}, {2, 3}, {4, 5}, {7, 7}, {0, 3}};
  for (const auto& [pairs, expected_fraction] : {std::pair{partial, 0.3}, std::pair{whole, 0.0}}) {
    OptimizerStageOptions o;
    o.mutual_placement_max_gap_m = 0.0;  // other rules under test
    o.placement_heading_variance_ratio = 2.0;
    Pose2 T_0_1;
    const auto T = PlaceWithHeadings(o, pairs, &T_0_1);
    ASSERT_TRUE(T.has_value());
    EXPECT_NEAR(T->yaw_rad, T_0_1.yaw_rad + expected_fraction * 0.1, 1e-4) << expected_fraction;
  }
}

// max_rotation_lever_m: the teammate's keyframes (0, 2k), k = 0..7, lie at an RMS distance
// L = sqrt(21 + 1.8^2) = 4.9234 m from the loops' teammate-keyframe centroid (0, 8.8); with
// u = 6/7 and ratio 2 the rotation's sigma is sqrt(u 2 / (u + 2)) = sqrt(0.6) of one map's,
// the lever 3.8136 m; without the headings' variance model (ratio 0) sqrt(u): 4.5582 m. Loops
// that span both missions (u = 0) leave no lever.
TEST(OptimizerStage, WaitsWhileTheTeammatesMapReachesFarFromItsLocalLoops) {
  const std::vector<std::pair<int, int>> partial{{1, 2}, {3, 4}, {5, 6}, {1, 4}, {3, 6}};
  const std::vector<std::pair<int, int>> whole{{0, 0}, {2, 3}, {4, 5}, {7, 7}, {0, 3}};
  struct Case {
    std::vector<std::pair<int, int>> pairs;
    double ratio, max_lever_m, lever_m;
    bool placed;
  };
  for (const auto& c :
       {Case{partial, 2.0, 3.7, 3.8136, false}, Case{partial, 2.0, 3.9, 3.8136, true},
        Case{partial, 0.0, 4.5, 4.5582, false}, Case{partial, 0.0, 0.0, 4.5582, true},
        Case{whole, 2.0, 0.1, 0.0, true}}) {
    OptimizerStageOptions o;
    o.mutual_placement_max_gap_m = 0.0;  // other rules under test
    o.placement_heading_variance_ratio = c.ratio;
    o.max_rotation_lever_m = c.max_lever_m;
    Pose2 T_0_1;
    double lever_m = -1.0;
    std::string held;
    const auto T = PlaceWithHeadings(o, c.pairs, &T_0_1, &lever_m, &held);
    EXPECT_NEAR(lever_m, c.lever_m, 1e-3) << c.ratio << " " << c.max_lever_m;
    EXPECT_EQ(T.has_value(), c.placed) << c.ratio << " " << c.max_lever_m;
    EXPECT_EQ(held, c.placed ? "" : "lever") << c.ratio << " " << c.max_lever_m;
  }
}

// refine_min_pairs: loops place teammate 1 at T_0_1, but its six small objects lie on the own
// ones under T_true, 0.64 m and 1.1 deg from it (the loops' maps bend where they meet). With
// the refinement the placement is T_true; off, or with a move bound below the gap, T_0_1.
TEST(OptimizerStage, RefinesAPlacedTeammateOnTheObjectMaps) {
  const Pose2 T_true = reg::Compose(Pose2{0.5, -0.4, 0.02}, TeammateOne(nullptr).T_0_1);
  const msgs::Point2 piles[] = {{6.0, 3.0},   {10.0, -3.0}, {16.0, 2.0},
                                {20.0, -2.0}, {2.0, 12.0},  {-4.0, 8.0}};
  const auto run = [&](int min_pairs, double max_move_m, double blend_pairs = 0.0) {
    OptimizerStageOptions o = OtherRulesOptions();
    o.refine_min_pairs = min_pairs;
    o.refine_max_move_m = max_move_m;
    o.refine_blend_pairs = blend_pairs;
    o.max_map_miss_fraction = 1.0;  // no own sonar returns here: the map check off
    OptimizerStage stage(o);
    const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
    const TeammateOne mate(&stage);
    msgs::ObjectMap own, mate_map;
    for (std::uint32_t i = 0; i < 6; ++i) {
      msgs::Object ob;
      ob.id = i;
      ob.length_m = ob.breadth_m = 1.0;
      ob.center = ob.rect_center = piles[i];
      own.objects.push_back(ob);
      ob.center = ob.rect_center = reg::Apply(reg::Inverse(T_true), piles[i]);
      mate_map.objects.push_back(ob);
    }
    stage.OnOwnObjectMap(own);
    stage.OnTeammateObjectMap(mate.poses.header, mate_map);
    msgs::TeamStepStats st;
    stage.Step(20.0, mate.Loops(traj, 11, {{1, 2}, {3, 4}, {5, 6}, {1, 4}, {3, 6}}), mate.matches,
               &st);
    EXPECT_EQ(stage.estimate().trajectories.count(1), 1u);
    return stage.estimate().T_own_teammate.at(1);
  };
  const Pose2 T_0_1 = TeammateOne(nullptr).T_0_1;
  const auto near = [](const Pose2& a, const Pose2& b) {
    return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m) < 1e-3 &&
           std::abs(a.yaw_rad - b.yaw_rad) < 1e-4;
  };
  EXPECT_TRUE(near(run(0, 3.0), T_0_1));   // off
  EXPECT_TRUE(near(run(5, 3.0), T_true));  // refined onto the objects
  EXPECT_TRUE(near(run(7, 3.0), T_0_1));   // six pairs are too few
  EXPECT_TRUE(near(run(5, 0.3), T_0_1));   // the move is more than 0.3 m
  // Blended: six pairs against refine_blend_pairs 6 move half the way, the turn included.
  const Pose2 half = run(5, 3.0, 6.0);
  EXPECT_NEAR(half.yaw_rad, T_0_1.yaw_rad + 0.01, 1e-4);
  // The teammate's keyframe centroid (0, 7) lands half way between the two placements.
  const Pose2 centroid{0.0, 7.0, 0.0};
  const Pose2 p = reg::Compose(half, centroid), p0 = reg::Compose(T_0_1, centroid),
              p1 = reg::Compose(T_true, centroid);
  EXPECT_NEAR(p.x_m, 0.5 * (p0.x_m + p1.x_m), 1e-3);
  EXPECT_NEAR(p.y_m, 0.5 * (p0.y_m + p1.y_m), 1e-3);
}

TEST(OptimizerStage, PlacesATeammateOnlyOnIndependentLoops) {
  // Robot 1 at T_0_1. Seven true loops that all name one teammate keyframe (one scan
  // registered against several own windows) do not place it; five over three distinct
  // keyframes of each robot do; when the filter withdraws them, the placement is withdrawn.
  OptimizerStageOptions o;
  o.mutual_placement_max_gap_m = 0.0;  // other rules under test
  o.robot_id = 0;
  o.optimize_period_s = 0.0;
  OptimizerStage stage(o);
  const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
  const TeammateOne mate(&stage);
  const Pose2 T_0_1 = mate.T_0_1;
  const msgs::KeyframePoses& p = mate.poses;
  const msgs::MapMatches& matches = mate.matches;
  const auto loop = [&](std::uint64_t id, int own_k, int mate_k) {
    return mate.Loop(traj, id, own_k, mate_k);
  };
  std::vector<msgs::InterRobotLoop> one_scan;
  for (int k = 0; k < 7; ++k) one_scan.push_back(loop(k + 1, k, 3));
  msgs::TeamStepStats st;
  stage.Step(10.0, one_scan, matches, &st);
  EXPECT_EQ(stage.estimate().trajectories.count(1), 0u);
  EXPECT_EQ(stage.estimate().held.at(1), "keyframes");
  EXPECT_TRUE(stage.SharedTransforms().empty());
  const std::vector<msgs::InterRobotLoop> independent{
      loop(11, 1, 2), loop(12, 3, 4), loop(13, 5, 6), loop(14, 1, 4), loop(15, 3, 6)};
  stage.Step(20.0, independent, matches, &st);
  ASSERT_EQ(stage.estimate().trajectories.count(1), 1u);
  EXPECT_EQ(stage.estimate().held.count(1), 0u);
  const Pose2 T = stage.estimate().T_own_teammate.at(1);
  EXPECT_NEAR(T.x_m, T_0_1.x_m, 1e-3);
  EXPECT_NEAR(T.y_m, T_0_1.y_m, 1e-3);
  EXPECT_NEAR(T.yaw_rad, T_0_1.yaw_rad, 1e-4);
  ASSERT_EQ(stage.SharedTransforms().size(), 1u);
  // Rejected candidates that agree on another transform (4 m off along x, as a pile grid one
  // spacing off) over three keyframes of each robot: the evidence is contested, no placement.
  const Pose2 T_rival{T_0_1.x_m + 4.0, T_0_1.y_m, T_0_1.yaw_rad};
  auto contested = independent;
  for (int k = 0; k < 3; ++k) {
    auto l = loop(21 + k, 2 * k + 2, 2 * k + 1);
    l.T_ownkf_teammatekf = reg::Between(traj.keyframes[2 * k + 2].T_map_kf,
                                        reg::Compose(T_rival, p.poses[2 * k + 1].T_map_kf));
    l.flags = msgs::kLoopRejected;
    contested.push_back(l);
  }
  stage.Step(25.0, contested, matches, &st);
  EXPECT_EQ(stage.estimate().trajectories.count(1), 0u);
  EXPECT_EQ(stage.estimate().held.at(1), "rival");
  // Scattered rejected candidates (no two agree) do not contest it.
  auto scattered = independent;
  for (int k = 0; k < 3; ++k) {
    auto l = loop(31 + k, 2 * k + 2, 2 * k + 1);
    const Pose2 T_off{T_0_1.x_m + 4.0 * (k + 1), T_0_1.y_m - 3.0 * k, T_0_1.yaw_rad + 0.5 * k};
    l.T_ownkf_teammatekf = reg::Between(traj.keyframes[2 * k + 2].T_map_kf,
                                        reg::Compose(T_off, p.poses[2 * k + 1].T_map_kf));
    l.flags = msgs::kLoopRejected;
    scattered.push_back(l);
  }
  stage.Step(27.0, scattered, matches, &st);
  EXPECT_EQ(stage.estimate().trajectories.count(1), 1u);
  auto withdrawn = independent;
  for (auto& l : withdrawn) l.flags = msgs::kLoopRejected;
  stage.Step(30.0, withdrawn, matches, &st);
  EXPECT_EQ(stage.estimate().trajectories.count(1), 0u);
  EXPECT_TRUE(stage.SharedTransforms().empty());
}

TEST(OptimizerStage, PlacesATeammateOnlyOnceItPlacedThisRobotTooAndTheyAgree) {
  // Five independent true loops verify robot 1 (as above); with mutual placement on it is
  // shared but not placed until robot 1 shares its own placement of robot 0, and placed only
  // when T_0_1 * T_1_0 moves the own keyframes by less than the gap.
  OptimizerStageOptions o;
  o.mutual_placement_max_gap_m = 0.0;  // other rules under test
  o.robot_id = 0;
  o.optimize_period_s = 0.0;
  o.mutual_placement_max_gap_m = 2.0;
  OptimizerStage stage(o);
  const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
  const TeammateOne mate(&stage);
  const std::vector<msgs::InterRobotLoop> loops{
      mate.Loop(traj, 11, 1, 2), mate.Loop(traj, 12, 3, 4), mate.Loop(traj, 13, 5, 6),
      mate.Loop(traj, 14, 1, 4), mate.Loop(traj, 15, 3, 6)};
  msgs::TeamStepStats st;
  stage.Step(10.0, loops, mate.matches, &st);
  EXPECT_EQ(stage.estimate().trajectories.count(1), 0u);
  EXPECT_EQ(stage.estimate().held.at(1), "mutual");
  ASSERT_EQ(stage.SharedTransforms().size(), 1u);  // shared while it waits: no deadlock
  EXPECT_NEAR(stage.SharedTransforms()[0].T_sender_robot.x_m, mate.T_0_1.x_m, 1e-3);
  const auto share = [&](const Pose2& T_1_0) {
    msgs::TeammateTransforms t;
    t.header.robot_id = 1;
    t.header.incarnation = 1;
    t.transforms = {{0, T_1_0}};
    stage.OnTeammateTransforms(t);
  };
  // Robot 1's placement of robot 0 turned by 0.6 rad about robot 1's origin: the own keyframes
  // (RMS 5.1 m from there) move by 3.0 m RMS.
  const Pose2 T_1_0 = reg::Inverse(mate.T_0_1);
  share(reg::Compose(Pose2{0.0, 0.0, 0.6}, T_1_0));
  stage.Step(20.0, loops, mate.matches, &st);
  EXPECT_EQ(stage.estimate().trajectories.count(1), 0u);
  // 1 m off along x: within 2 m, placed.
  share(reg::Compose(Pose2{1.0, 0.0, 0.0}, T_1_0));
  stage.Step(30.0, loops, mate.matches, &st);
  ASSERT_EQ(stage.estimate().trajectories.count(1), 1u);
  EXPECT_EQ(stage.estimate().held.count(1), 0u);
  EXPECT_NEAR(stage.estimate().T_own_teammate.at(1).x_m, mate.T_0_1.x_m, 1e-3);
  // The two cannot be combined.
  o.place_chained_teammates = true;
  EXPECT_THROW(OptimizerStage{o}, std::invalid_argument);
}

// settle_s 30: five independent true loops place robot 1 at T_0_1, but only once that
// placement has held for 30 s (steps without new loops place it when the time is up). Loops
// that move it 3 m (five others, replacing the first) start the wait again; off, each
// placement is in the estimate at once.
TEST(OptimizerStage, PlacesATeammateOnlyOnceItsPlacementHasHeld) {
  const auto run = [](double settle_s) {
    OptimizerStageOptions o = OtherRulesOptions();
    o.settle_s = settle_s;
    o.settle_max_move_m = 1.0;
    OptimizerStage stage(o);
    const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
    const TeammateOne mate(&stage);
    const std::vector<msgs::InterRobotLoop> first =
        mate.Loops(traj, 11, {{1, 2}, {3, 4}, {5, 6}, {1, 4}, {3, 6}});
    const Pose2 T_moved{mate.T_0_1.x_m + 3.0, mate.T_0_1.y_m, mate.T_0_1.yaw_rad};
    std::vector<msgs::InterRobotLoop> moved =
        mate.Loops(traj, 21, {{2, 1}, {4, 3}, {6, 5}, {2, 5}, {4, 7}});
    for (auto& l : moved) {
      l.T_ownkf_teammatekf = reg::Between(
          traj.keyframes[static_cast<std::size_t>(l.own_keyframe)].T_map_kf,
          reg::Compose(T_moved,
                       mate.poses.poses[static_cast<std::size_t>(l.teammate_keyframe)].T_map_kf));
    }
    std::vector<std::pair<std::string, std::optional<Pose2>>> seen;  // held, T per step
    msgs::TeamStepStats st;
    const auto step = [&](double t_s, const std::vector<msgs::InterRobotLoop>& loops) {
      stage.Step(t_s, loops, mate.matches, &st);
      const auto& e = stage.estimate();
      const auto h = e.held.find(1);
      const auto T = e.T_own_teammate.find(1);
      EXPECT_EQ(e.trajectories.count(1), T != e.T_own_teammate.end() ? 1u : 0u) << t_s;
      EXPECT_EQ(stage.SharedTransforms().size(), 1u) << t_s;  // shared while it waits
      seen.emplace_back(h != e.held.end() ? h->second : "", T != e.T_own_teammate.end()
                                                                ? std::optional<Pose2>(T->second)
                                                                : std::nullopt);
    };
    step(10.0, first);
    step(25.0, first);
    step(41.0, first);
    step(50.0, moved);
    step(70.0, moved);
    step(81.0, moved);
    return seen;
  };
  const Pose2 T_0_1 = TeammateOne(nullptr).T_0_1;
  const auto at = [](const std::optional<Pose2>& T, double x_m) {
    return T.has_value() && std::abs(T->x_m - x_m) < 1e-3;
  };
  const auto settled = run(30.0);
  ASSERT_EQ(settled.size(), 6u);
  for (const int i : {0, 1, 3, 4}) {
    EXPECT_EQ(settled[i].first, "settling") << i;
    EXPECT_FALSE(settled[i].second.has_value()) << i;
  }
  EXPECT_EQ(settled[2].first, "");  // held 31 s
  EXPECT_TRUE(at(settled[2].second, T_0_1.x_m));
  EXPECT_EQ(settled[5].first, "");  // the moved placement held 31 s
  EXPECT_TRUE(at(settled[5].second, T_0_1.x_m + 3.0));
  const auto off = run(0.0);
  for (const int i : {0, 1, 2}) EXPECT_TRUE(at(off[i].second, T_0_1.x_m)) << i;
  for (const int i : {3, 4, 5}) EXPECT_TRUE(at(off[i].second, T_0_1.x_m + 3.0)) << i;
}

TEST(OptimizerStage, ObjectMapsThatContradictThePlacementKeepItOut) {
  // Five independent true loops place robot 1 (as above) while the teammate's objects lie on
  // own sonar returns under them. When the teammate's map holds three more objects where the
  // own sonar looked and saw nothing (a structure turned onto open water), the teammate is not
  // placed; with the check off it is. Behind a wall of own returns the same three are in
  // its shadow, not expected.
  const auto run = [](double max_map_miss_fraction, bool contradict,
                      double own_heading_rad = msgs::kUnknownHeading,
                      double mate_heading_rad = msgs::kUnknownHeading, bool wall = false,
                      double shadow_margin_m =
                          OptimizerStageOptions{}.map_coverage.shadow_margin_m) {
    OptimizerStageOptions o = OtherRulesOptions();
    o.max_map_miss_fraction = max_map_miss_fraction;
    o.map_coverage.shadow_margin_m = shadow_margin_m;
    auto stage = std::make_unique<OptimizerStage>(o);
    // Objects in the own map frame, in front of the own keyframes (x 0..14, facing +x), each
    // keyframe returning a point on each of them; the teammate's map holds the same ones in
    // its frame, and with `contradict` three more on the own empty water.
    const msgs::Point2 shared[] = {{6.0, 3.0}, {10.0, -3.0}, {16.0, 2.0}, {20.0, -2.0}};
    const msgs::Point2 extra[] = {{25.0, 5.0}, {28.0, -5.0}, {31.0, 0.0}};
    msgs::KeyframeTrajectory traj;
    for (int k = 0; k < 8; ++k) {
      msgs::Keyframe kf;
      kf.index = k;
      kf.time_s = k;
      kf.T_odom_body = {2.0 * k, 0.0, 0.0};
      for (const auto& c : shared) kf.points_body.push_back({c.x_m - 2.0 * k, c.y_m});
      if (wall) {  // a wall across x = 23 m, between the shared objects and the extra ones
        for (double y = -8.0; y <= 8.0; y += 0.5) kf.points_body.push_back({23.0 - 2.0 * k, y});
      }
      stage->OnKeyframe(kf);
      traj.keyframes.push_back({k, double(k), kf.T_odom_body});
    }
    stage->OnTrajectory(traj);
    const TeammateOne mate(stage.get());
    const Pose2 T_0_1 = mate.T_0_1;
    std::vector<msgs::InterRobotLoop> loops;
    const std::pair<int, int> pairs[] = {{1, 2}, {3, 4}, {5, 6}, {1, 4}, {3, 6}};
    for (const auto& [own_k, mate_k] : pairs)
      loops.push_back(mate.Loop(traj, loops.size() + 1, own_k, mate_k));
    msgs::ObjectMap own, mate_map;
    const Pose2 T_1_0 = reg::Inverse(T_0_1);
    const auto object = [](std::uint32_t id, const msgs::Point2& c) {
      msgs::Object ob;
      ob.id = id;
      ob.center = ob.rect_center = c;
      ob.length_m = ob.breadth_m = 1.0;
      return ob;
    };
    for (std::uint32_t i = 0; i < 4; ++i) {
      own.objects.push_back(object(i, shared[i]));
      mate_map.objects.push_back(object(i, reg::Apply(T_1_0, shared[i])));
    }
    if (contradict) {
      for (std::uint32_t i = 0; i < 3; ++i) {
        mate_map.objects.push_back(object(10 + i, reg::Apply(T_1_0, extra[i])));
      }
    }
    own.map_heading_rad = own_heading_rad;
    mate_map.map_heading_rad = mate_heading_rad;
    stage->OnOwnObjectMap(own);
    stage->OnTeammateObjectMap(mate.poses.header, mate_map);
    msgs::TeamStepStats st;
    stage->Step(10.0, loops, mate.matches, &st);
    return stage;
  };
  const auto agree = run(0.1, false);
  ASSERT_EQ(agree->estimate().trajectories.count(1), 1u);
  ASSERT_EQ(agree->estimate().map_checks.count(1), 1u);
  const MapCheck& fine = agree->estimate().map_checks.at(1);
  EXPECT_EQ(fine.support.expected, 4);
  EXPECT_EQ(fine.support.met, 4);
  EXPECT_EQ(fine.agreement.b_expected, 4);  // the objects-against-objects count agrees
  EXPECT_EQ(fine.agreement.b_met, 4);
  EXPECT_FALSE(fine.contradicted);
  EXPECT_NEAR(fine.T_own_teammate.x_m, 5.0, 1e-6);
  EXPECT_NEAR(fine.T_own_teammate.yaw_rad, 0.3, 1e-6);

  const auto contradicted = run(0.1, true);
  EXPECT_EQ(contradicted->estimate().trajectories.count(1), 0u);
  EXPECT_TRUE(contradicted->SharedTransforms().empty());
  ASSERT_EQ(contradicted->estimate().map_checks.count(1), 1u);
  const MapCheck& bad = contradicted->estimate().map_checks.at(1);
  EXPECT_TRUE(bad.contradicted);
  EXPECT_EQ(bad.support.expected, 7);
  EXPECT_EQ(bad.support.met, 4);

  const auto off = run(1.0, true);
  EXPECT_EQ(off->estimate().trajectories.count(1), 1u);
  ASSERT_EQ(off->estimate().map_checks.count(1), 1u);  // the headings' check only
  EXPECT_EQ(off->estimate().map_checks.at(1).support.expected, 0);
  EXPECT_FALSE(off->estimate().map_checks.at(1).contradicted);
  EXPECT_TRUE(std::isnan(off->estimate().map_checks.at(1).heading_gap_rad));

  // Behind a wall the own sonar hit, the water is not seen: the three extra objects there
  // are not expected (the default shadows), and the teammate is placed. Without shadows they
  // are expected on the empty water, and it is not.
  ASSERT_GT(OptimizerStageOptions{}.map_coverage.shadow_margin_m, 0.0);
  const auto walled = run(0.1, true, msgs::kUnknownHeading, msgs::kUnknownHeading, true);
  EXPECT_EQ(walled->estimate().trajectories.count(1), 1u);
  ASSERT_EQ(walled->estimate().map_checks.count(1), 1u);
  EXPECT_FALSE(walled->estimate().map_checks.at(1).contradicted);
  EXPECT_EQ(walled->estimate().map_checks.at(1).support.expected, 4);
  EXPECT_EQ(walled->estimate().map_checks.at(1).support.met, 4);
  const auto unshadowed = run(0.1, true, msgs::kUnknownHeading, msgs::kUnknownHeading, true, 0.0);
  EXPECT_EQ(unshadowed->estimate().trajectories.count(1), 0u);
  ASSERT_EQ(unshadowed->estimate().map_checks.count(1), 1u);
  EXPECT_TRUE(unshadowed->estimate().map_checks.at(1).contradicted);
  EXPECT_EQ(unshadowed->estimate().map_checks.at(1).support.expected, 7);
}

// The two-step PGO's warm start (OptimizerStageOptions::warm_start): the same estimates as
// solving from scratch, step after step, as the own trajectory grows and loops are added.
TEST(OptimizerStage, WarmStartGivesTheColdEstimates) {
  std::array<TeamEstimate, 2> first, grown;
  std::array<int, 2> optimized{};
  for (const bool warm : {false, true}) {
    OptimizerStageOptions o = OtherRulesOptions();
    o.warm_start = warm;
    OptimizerStage stage(o);
    const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
    TeammateOne mate(&stage);
    mate.matches.guesses[1].match.T_a_b = {6.0, 0.2, 0.4};  // the loops move it to T_0_1
    const std::vector<std::pair<int, int>> pairs{{1, 2}, {3, 4}, {5, 6}, {1, 4}, {3, 6}};
    std::vector<msgs::InterRobotLoop> loops = mate.Loops(traj, 11, pairs);
    loops[1].T_ownkf_teammatekf.x_m += 0.05;  // loops that disagree a little
    loops[3].T_ownkf_teammatekf.yaw_rad -= 0.01;
    msgs::TeamStepStats st;
    stage.Step(20.0, loops, mate.matches, &st);
    optimized[warm] += st.optimized;
    first[warm] = stage.estimate();
    // Four more own keyframes and a loop from one of them: solved again (a changed input
    // is never skipped), every own keyframe placed.
    const msgs::KeyframeTrajectory longer = OwnStraightLine(&stage, 12);
    loops.push_back(mate.Loop(longer, 21, 10, 7));
    st = {};
    stage.Step(40.0, loops, mate.matches, &st);
    optimized[warm] += st.optimized;
    grown[warm] = stage.estimate();
  }
  EXPECT_EQ(optimized[0], 2);
  EXPECT_EQ(optimized[1], 2);
  for (const auto* e : {&first, &grown}) {
    const auto& cold = (*e)[0];
    const auto& warm = (*e)[1];
    ASSERT_EQ(cold.trajectories.size(), 2u);
    ASSERT_EQ(warm.trajectories.size(), 2u);
    for (const auto& [r, t] : cold.trajectories) {
      const auto& w = warm.trajectories.at(r);
      ASSERT_EQ(t.size(), w.size()) << r;
      for (std::size_t k = 0; k < t.size(); ++k) {
        EXPECT_EQ(t[k].index, w[k].index);
        EXPECT_NEAR(t[k].T_map_kf.x_m, w[k].T_map_kf.x_m, 1e-4) << r << " " << k;
        EXPECT_NEAR(t[k].T_map_kf.y_m, w[k].T_map_kf.y_m, 1e-4) << r << " " << k;
        EXPECT_NEAR(t[k].T_map_kf.yaw_rad, w[k].T_map_kf.yaw_rad, 1e-5) << r << " " << k;
      }
    }
    const Pose2 a = cold.T_own_teammate.at(1), b = warm.T_own_teammate.at(1);
    EXPECT_NEAR(a.x_m, b.x_m, 1e-4);
    EXPECT_NEAR(a.y_m, b.y_m, 1e-4);
    EXPECT_NEAR(a.yaw_rad, b.yaw_rad, 1e-5);
  }
  EXPECT_EQ(grown[1].trajectories.at(0).size(), 12u);
  EXPECT_NEAR(grown[1].T_own_teammate.at(1).x_m, 5.0, 0.05);  // at T_0_1, not the guess
}

// The filter switches cliques: six loops that placed teammate 1 three spacings of a pile row
// off (12 m along x) are replaced by six at the truth, three of them naming the teammate
// keyframe a wrong loop that stays accepted names too, and the matcher's guess moves to the
// truth. Started from the old solution, that keyframe would stay in the wrong loop's minimum
// of the robust cost; the solve after the switch starts afresh and gives the cold estimate.
TEST(OptimizerStage, WarmStartIsDroppedWhenTheAcceptedLoopsChange) {
  std::array<TeamEstimate, 2> wrong, undone;
  for (const bool warm : {false, true}) {
    OptimizerStageOptions o = OtherRulesOptions();
    o.warm_start = warm;
    o.competitor_ratio = 0.0;  // the withdrawn loops would contest the new ones: not here
    OptimizerStage stage(o);
    const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
    TeammateOne mate(&stage);
    const Pose2 T_0_1 = mate.T_0_1;
    const Pose2 T_wrong{T_0_1.x_m + 12.0, T_0_1.y_m, T_0_1.yaw_rad};
    mate.matches.guesses[1].match.T_a_b = T_wrong;  // the matcher took the shifted fit too
    mate.T_0_1 = T_wrong;
    const std::vector<std::pair<int, int>> old_pairs{{1, 2}, {3, 4}, {5, 6},
                                                     {1, 4}, {3, 6}, {7, 5}};
    std::vector<msgs::InterRobotLoop> loops = mate.Loops(traj, 11, old_pairs);
    msgs::TeamStepStats st;
    stage.Step(20.0, loops, mate.matches, &st);
    ASSERT_TRUE(st.optimized);
    wrong[warm] = stage.estimate();
    for (std::size_t i = 1; i < loops.size(); ++i) loops[i].flags = msgs::kLoopRejected;
    mate.T_0_1 = T_0_1;
    mate.matches.guesses[1].match.T_a_b = T_0_1;
    mate.matches.guesses[1].match_count = 2;
    const std::vector<std::pair<int, int>> new_pairs{{1, 2}, {3, 2}, {5, 2},
                                                     {3, 4}, {5, 6}, {7, 6}};
    for (const auto& l : mate.Loops(traj, 21, new_pairs)) loops.push_back(l);
    st = {};
    stage.Step(40.0, loops, mate.matches, &st);
    ASSERT_TRUE(st.optimized);
    undone[warm] = stage.estimate();
  }
  for (const auto& e : wrong) EXPECT_NEAR(e.T_own_teammate.at(1).x_m, 17.0, 0.05);
  for (const auto& e : undone) {
    ASSERT_EQ(e.trajectories.count(1), 1u);
    EXPECT_NEAR(e.T_own_teammate.at(1).x_m, 5.0, 0.3);
    EXPECT_NEAR(e.T_own_teammate.at(1).y_m, 1.0, 0.3);
    EXPECT_NEAR(e.T_own_teammate.at(1).yaw_rad, 0.3, 0.02);
  }
  const auto& cold = undone[0].trajectories.at(1);
  const auto& hot = undone[1].trajectories.at(1);
  ASSERT_EQ(cold.size(), hot.size());
  for (std::size_t k = 0; k < cold.size(); ++k) {
    EXPECT_NEAR(cold[k].T_map_kf.x_m, hot[k].T_map_kf.x_m, 1e-4) << k;
    EXPECT_NEAR(cold[k].T_map_kf.y_m, hot[k].T_map_kf.y_m, 1e-4) << k;
    EXPECT_NEAR(cold[k].T_map_kf.yaw_rad, hot[k].T_map_kf.yaw_rad, 1e-5) << k;
  }
}

// Loops that disagree by 0.3 m bend the global step's chain of teammate 1. With
// rigid_teammate_trajectories its trajectory is its shared keyframe poses moved by
// T_own_teammate (the fit of that chain); without, the bent chain. The placement is the same.
TEST(OptimizerStage, PlacedTeammateIsItsLocalSlamMovedByThePlacement) {
  std::array<TeamEstimate, 2> est;
  msgs::KeyframePoses shared;
  for (const bool rigid : {false, true}) {
    OptimizerStageOptions o = OtherRulesOptions();
    o.rigid_teammate_trajectories = rigid;
    OptimizerStage stage(o);
    const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
    const TeammateOne mate(&stage);
    shared = mate.poses;
    const std::vector<std::pair<int, int>> pairs{{1, 0}, {3, 2}, {5, 4}, {7, 7}, {2, 1}, {6, 6}};
    std::vector<msgs::InterRobotLoop> loops = mate.Loops(traj, 11, pairs);
    loops[2].T_ownkf_teammatekf.x_m += 0.3;
    loops[3].T_ownkf_teammatekf.y_m -= 0.3;
    msgs::TeamStepStats st;
    stage.Step(20.0, loops, mate.matches, &st);
    ASSERT_TRUE(st.optimized);
    est[rigid] = stage.estimate();
    ASSERT_EQ(est[rigid].trajectories.count(1), 1u);
  }
  const Pose2 a = est[0].T_own_teammate.at(1), b = est[1].T_own_teammate.at(1);
  EXPECT_EQ(a.x_m, b.x_m);
  EXPECT_EQ(a.y_m, b.y_m);
  EXPECT_EQ(a.yaw_rad, b.yaw_rad);
  EXPECT_NEAR(b.x_m, 5.0, 0.2);
  EXPECT_NEAR(b.y_m, 1.0, 0.2);
  double bent_m = 0.0;
  for (const bool rigid : {false, true}) {
    const auto& t = est[rigid].trajectories.at(1);
    ASSERT_EQ(t.size(), shared.poses.size());
    for (std::size_t k = 0; k < t.size(); ++k) {
      const Pose2 moved = reg::Compose(est[rigid].T_own_teammate.at(1), shared.poses[k].T_map_kf);
      const double d = std::hypot(t[k].T_map_kf.x_m - moved.x_m, t[k].T_map_kf.y_m - moved.y_m);
      if (rigid) {
        EXPECT_LT(d, 1e-9) << k;
        EXPECT_NEAR(std::remainder(t[k].T_map_kf.yaw_rad - moved.yaw_rad, 2 * M_PI), 0.0, 1e-9);
      } else {
        bent_m = std::max(bent_m, d);
      }
    }
  }
  EXPECT_GT(bent_m, 0.02);  // the bent chain is not a rigid copy
}

// Every own keyframe of a repeated pass tied to teammate keyframes 2, 4 and 6: 24 accepted
// true loops. The PGO holds the first max_loops_per_teammate_keyframe of each teammate
// keyframe (12 at 4, 3 at 1, all 24 at 0) and places the teammate at the truth either way;
// the placement evidence counts every accepted loop, so one loop a keyframe still places it.
TEST(OptimizerStage, PgoHoldsTheFirstLoopsOfEachTeammateKeyframe) {
  for (const auto& [bound, held] : std::vector<std::pair<int, int>>{{0, 24}, {4, 12}, {1, 3}}) {
    OptimizerStageOptions o = OtherRulesOptions();
    o.max_loops_per_teammate_keyframe = bound;
    OptimizerStage stage(o);
    const msgs::KeyframeTrajectory traj = OwnStraightLine(&stage, 8);
    TeammateOne mate(&stage);
    mate.matches.guesses[1].match.T_a_b = {6.0, 0.2, 0.4};  // the loops move it to T_0_1
    std::vector<msgs::InterRobotLoop> loops;
    std::uint64_t id = 1;
    for (int own_k = 0; own_k < 8; ++own_k) {
      for (const int mate_k : {2, 4, 6}) loops.push_back(mate.Loop(traj, id++, own_k, mate_k));
    }
    msgs::TeamStepStats st;
    stage.Step(20.0, loops, mate.matches, &st);
    ASSERT_TRUE(st.optimized) << bound;
    EXPECT_EQ(stage.estimate().loops_in_pgo, held) << bound;
    ASSERT_EQ(stage.estimate().trajectories.count(1), 1u) << bound;
    const Pose2 T = stage.estimate().T_own_teammate.at(1);
    EXPECT_NEAR(T.x_m, mate.T_0_1.x_m, 1e-3) << bound;
    EXPECT_NEAR(T.y_m, mate.T_0_1.y_m, 1e-3) << bound;
    EXPECT_NEAR(T.yaw_rad, mate.T_0_1.yaw_rad, 1e-4) << bound;
  }
}

TEST(OptimizerStage, AbsoluteHeadingsKeepATurnedPlacementOut) {
  // The loops place robot 1 with a rotation of 0.3 rad (TeammateOne). Map headings whose
  // difference is 0.3 rad (give or take the AHRS's error) allow it; headings that say the
  // teammate's map is turned the other way (a grid flipped 180 deg) keep it out, and so does
  // a quarter turn; unknown headings do not judge.
  const auto run = [](double own_heading_rad, double mate_heading_rad, double max_gap_rad) {
    OptimizerStageOptions o = OtherRulesOptions();
    o.max_map_miss_fraction = 1.0;  // the headings alone
    o.max_heading_gap_rad = max_gap_rad;
    auto stage = std::make_unique<OptimizerStage>(o);
    const msgs::KeyframeTrajectory traj = OwnStraightLine(stage.get(), 8);
    const TeammateOne mate(stage.get());
    std::vector<msgs::InterRobotLoop> loops;
    const std::pair<int, int> pairs[] = {{1, 2}, {3, 4}, {5, 6}, {1, 4}, {3, 6}};
    for (const auto& [own_k, mate_k] : pairs)
      loops.push_back(mate.Loop(traj, loops.size() + 1, own_k, mate_k));
    msgs::ObjectMap own, mate_map;
    msgs::Object ob;
    ob.length_m = ob.breadth_m = 1.0;
    own.objects = mate_map.objects = {ob};
    own.map_heading_rad = own_heading_rad;
    mate_map.map_heading_rad = mate_heading_rad;
    stage->OnOwnObjectMap(own);
    stage->OnTeammateObjectMap(mate.poses.header, mate_map);
    msgs::TeamStepStats st;
    stage->Step(10.0, loops, mate.matches, &st);
    return stage;
  };
  const double gap = 0.5236;
  const auto right = run(1.0, 1.3 + 0.05, gap);
  EXPECT_EQ(right->estimate().trajectories.count(1), 1u);
  ASSERT_EQ(right->estimate().map_checks.count(1), 1u);
  EXPECT_NEAR(right->estimate().map_checks.at(1).heading_gap_rad, -0.05, 1e-6);
  const auto flipped = run(1.0, 1.3 + M_PI, gap);
  EXPECT_EQ(flipped->estimate().trajectories.count(1), 0u);
  EXPECT_TRUE(flipped->SharedTransforms().empty());
  ASSERT_EQ(flipped->estimate().map_checks.count(1), 1u);
  EXPECT_TRUE(flipped->estimate().map_checks.at(1).contradicted);
  EXPECT_NEAR(std::abs(flipped->estimate().map_checks.at(1).heading_gap_rad), M_PI, 1e-6);
  EXPECT_EQ(run(1.0, 1.3 + 0.5 * M_PI, gap)->estimate().trajectories.count(1), 0u);
  EXPECT_EQ(run(1.0, 1.3 + M_PI, 0.0)->estimate().trajectories.count(1), 1u);  // off
  EXPECT_EQ(run(msgs::kUnknownHeading, 1.3 + M_PI, gap)->estimate().trajectories.count(1), 1u);
}

// A 5 x 5 grid of piles 4 m apart looks the same turned by 90, 180 or 270 deg about its centre.
// Robot A's keyframes 0-6 along x image it; robot B, whose map frame is T_A_B in A's, sends one
// scan of it. With neither map's absolute heading the registration ambiguity test finds the
// turned fits and refuses the registration (and by default also with them); with both headings
// known and headings_prune_turns the compass excludes the turns and the registration is a
// candidate; with headings that contradict the guess the registration is refused.
struct GridExchange {
  static constexpr double kGap = 0.5236;
  Pose2 T_A_B{5.0, 3.0, 0.3};
  std::vector<Point2> world;

  GridExchange() {
    for (int u = -2; u <= 2; ++u) {
      for (int v = -2; v <= 2; ++v) {
        for (int k = 0; k < 12; ++k) {
          const double a = k * std::numbers::pi / 6.0;
          world.push_back({18.0 + 4.0 * u + 0.3 * std::cos(a), 4.0 * v + 0.3 * std::sin(a)});
        }
      }
    }
  }
  std::vector<Point2> Seen(const Pose2& T_world_body) const {
    std::vector<Point2> out;
    for (const auto& p : world) out.push_back(reg::Apply(reg::Inverse(T_world_body), p));
    return out;
  }
  // Runs one exchange step; returns the configured window's registration status.
  // before: called on the stage before any input (the filter's candidates, OnLoops).
  std::pair<reg::RegistrationStatus, std::vector<msgs::InterRobotLoop>> Run(
      double own_heading, double mate_heading, bool prune_turns = true,
      const std::function<void(ScanExchangeStage&)>& before = {}) {
    ScanExchangeStageOptions o;
    o.robot_id = kA;
    o.log_windows = {};
    o.max_heading_gap_rad = kGap;
    o.headings_prune_turns = prune_turns;
    ScanExchangeStage stage(o);
    if (before) before(stage);
    msgs::KeyframeTrajectory traj;
    msgs::ObjectMap own;
    own.map_heading_rad = own_heading;
    msgs::Object pile;
    pile.id = 1;
    pile.center = pile.rect_center = {18.0, 0.0};
    pile.length_m = pile.breadth_m = 16.6;
    pile.num_points = 300;
    for (int i = 0; i < 7; ++i) {
      msgs::Keyframe kf;
      kf.index = i;
      kf.time_s = i;
      kf.T_odom_body = {1.0 * i, 0.0, 0.0};
      kf.points_body = Seen(kf.T_odom_body);
      stage.OnKeyframe(kf);
      traj.keyframes.push_back({i, kf.time_s, kf.T_odom_body});
      pile.keyframes.push_back(i);
    }
    traj.time_s = 6.0;
    stage.OnTrajectory(traj);
    own.objects.push_back(pile);
    const Pose2 W_b{3.0, 1.0, 0.1};  // B's keyframe in A's map frame (the world)
    const Pose2 P_b = reg::Compose(reg::Inverse(T_A_B), W_b);
    msgs::KeyframePoses poses;
    poses.header.robot_id = kB;
    poses.header.incarnation = 3;
    poses.full = true;
    poses.poses.push_back({0, 0.0, P_b, 300});
    stage.OnKeyframePoses(poses);
    msgs::ScanReply scan;
    scan.header = poses.header;
    scan.requester_robot = kA;
    scan.keyframe = 0;
    scan.T_map_kf = P_b;
    scan.points_kf = Seen(W_b);
    stage.OnScanReply(scan);
    msgs::MapMatches matches;
    auto& g = matches.guesses[kB];
    g.robot_id = kB;
    g.matched = true;
    g.match.status = msgs::MatchStatus::kMatched;
    g.match.T_a_b = T_A_B;
    g.teammate_map_heading_rad = mate_heading;
    msgs::TeamStepStats st;
    const auto out = stage.Step(10.0, own, matches, &st);
    EXPECT_FALSE(stage.attempts().empty());
    if (stage.attempts().empty()) return {reg::RegistrationStatus::kEmptyTarget, {}};
    return {stage.attempts().front().status, out.candidates};
  }
};

TEST(ScanExchangeStage, HeadingsSettleATurnAmbiguityAndRefuseATurnedRegistration) {
  GridExchange grid;
  const double nan = msgs::kUnknownHeading;
  const auto unknown = grid.Run(0.2, nan);
  EXPECT_EQ(unknown.first, reg::RegistrationStatus::kAmbiguous);
  EXPECT_TRUE(unknown.second.empty());
  // The default probes every turn whatever the headings: still ambiguous.
  EXPECT_EQ(grid.Run(0.2, 0.2 + grid.T_A_B.yaw_rad + 0.05, false).first,
            reg::RegistrationStatus::kAmbiguous);
  const auto known = grid.Run(0.2, 0.2 + grid.T_A_B.yaw_rad + 0.05);  // 3 deg AHRS error
  EXPECT_EQ(known.first, reg::RegistrationStatus::kAccepted);
  EXPECT_EQ(known.second.size(), 7u);  // one per own keyframe near the scan
  for (const auto& loop : known.second) {
    const Pose2 truth = reg::Between(Pose2{1.0 * loop.own_keyframe, 0.0, 0.0}, {3.0, 1.0, 0.1});
    const Pose2 e = reg::Between(truth, loop.T_ownkf_teammatekf);
    EXPECT_LT(std::hypot(e.x_m, e.y_m), 0.05) << loop.own_keyframe;
    EXPECT_LT(std::abs(e.yaw_rad), 0.005) << loop.own_keyframe;
  }
  // The compass says B's map is turned a further 45 deg: no turn is probed (each lands 45 deg
  // or more from it), and the registration, turned as the guess, is refused; by default the
  // turn probes refuse it first, as ambiguous.
  EXPECT_EQ(grid.Run(0.2, 0.2 + grid.T_A_B.yaw_rad + std::numbers::pi / 4, false).first,
            reg::RegistrationStatus::kAmbiguous);
  const auto turned = grid.Run(0.2, 0.2 + grid.T_A_B.yaw_rad + std::numbers::pi / 4);
  EXPECT_EQ(turned.first, reg::RegistrationStatus::kHeadingMismatch);
  EXPECT_TRUE(turned.second.empty());
  // Turned a further 90 deg: the 90 deg probe is one the compass allows, and it fits.
  const auto quarter = grid.Run(0.2, 0.2 + grid.T_A_B.yaw_rad + std::numbers::pi / 2);
  EXPECT_EQ(quarter.first, reg::RegistrationStatus::kAmbiguous);
  EXPECT_TRUE(quarter.second.empty());
}

// The filter's candidates (every one each step, numbered as taken) are never registered
// again: a step that would make one loop per own keyframe 0-6 with B's keyframe 0 leaves out
// those the filter holds, and after B is forgotten, the list sent again is taken again.
TEST(ScanExchangeStage, LeavesOutThePairsTheFilterHolds) {
  GridExchange grid;
  const double heading = 0.2 + grid.T_A_B.yaw_rad + 0.05;
  const auto loop = [](std::uint64_t id, int own_kf) {
    msgs::InterRobotLoop l;
    l.id = id;
    l.own_robot = kA;
    l.own_keyframe = own_kf;
    l.teammate_robot = kB;
    l.teammate_keyframe = 0;
    return l;
  };
  const auto own_keyframes = [](const std::vector<msgs::InterRobotLoop>& loops) {
    std::vector<int> out;
    for (const auto& l : loops) out.push_back(l.own_keyframe);
    std::sort(out.begin(), out.end());
    return out;
  };
  const auto all = grid.Run(0.2, heading);
  EXPECT_EQ(own_keyframes(all.second), (std::vector<int>{0, 1, 2, 3, 4, 5, 6}));
  const auto held = grid.Run(0.2, heading, true, [&](ScanExchangeStage& stage) {
    stage.OnLoops({loop(0, 2)});
    stage.OnLoops({loop(0, 2), loop(1, 5)});
  });
  EXPECT_EQ(own_keyframes(held.second), (std::vector<int>{0, 1, 3, 4, 6}));
  const auto forgotten = grid.Run(0.2, heading, true, [&](ScanExchangeStage& stage) {
    stage.OnLoops({loop(0, 2), loop(1, 5)});
    stage.Forget(kB);
    stage.OnLoops({loop(0, 2), loop(1, 5)});
  });
  EXPECT_EQ(own_keyframes(forgotten.second), (std::vector<int>{0, 1, 3, 4, 6}));
  const auto gone = grid.Run(0.2, heading, true, [&](ScanExchangeStage& stage) {
    stage.OnLoops({loop(0, 2), loop(1, 5)});
    stage.Forget(kB);
  });
  EXPECT_EQ(own_keyframes(gone.second), (std::vector<int>{0, 1, 2, 3, 4, 5, 6}));
}

// serve_submap_keyframes: A's keyframes 0-4 (poses (2k, 0, 0.1k)) hold 10 points each, fewer
// than the 30 a served scan needs; B asks for the scans of object 7, which keyframe 2 saw.
// Single keyframes: no reply. With 1 neighbour each side: keyframe 2 with the 10 points of
// each of keyframes 1 and 3 moved into its frame (30). With 2 and min_points 40: all 50.
TEST(ScanExchangeStage, ServesASparseKeyframeWithItsNeighboursPoints) {
  const auto pose = [](int k) { return Pose2{2.0 * k, 0.0, 0.1 * k}; };
  const auto point = [](int k, int i) { return Point2{1.0 + i, 0.5 * k}; };  // in keyframe k
  struct Case {
    int neighbours, min_points;
    std::size_t points;  // in the reply, 0: none
  };
  for (const auto& c : {Case{0, 30, 0}, Case{1, 30, 30}, Case{2, 40, 50}}) {
    ScanExchangeStageOptions o;
    o.robot_id = kA;
    o.serve_submap_keyframes = c.neighbours;
    o.selection.min_points = c.min_points;
    ScanExchangeStage stage(o);
    msgs::KeyframeTrajectory traj;
    for (int k = 0; k < 5; ++k) {
      msgs::Keyframe kf;
      kf.index = k;
      kf.time_s = k;
      kf.T_odom_body = pose(k);
      for (int i = 0; i < 10; ++i) kf.points_body.push_back(point(k, i));
      stage.OnKeyframe(kf);
      traj.keyframes.push_back({k, kf.time_s, pose(k)});
    }
    traj.time_s = 4.0;
    stage.OnTrajectory(traj);
    msgs::ObjectMap own;
    msgs::Object pile;
    pile.id = 7;
    pile.center = pile.rect_center = {4.0, 1.0};
    pile.length_m = pile.breadth_m = 1.0;
    pile.num_points = 10;
    pile.keyframes = {2};
    own.objects.push_back(pile);
    msgs::ScanRequest req;
    req.header.robot_id = kB;
    req.header.incarnation = 1;
    req.target_robot = kA;
    req.object_ids = {7};
    req.max_scans = 5;
    stage.OnScanRequest(req);
    msgs::TeamStepStats st;
    const auto out = stage.Step(10.0, own, msgs::MapMatches{}, &st);
    if (c.points == 0) {
      EXPECT_TRUE(out.replies.empty());
      continue;
    }
    ASSERT_EQ(out.replies.size(), 1u) << c.neighbours;
    const auto& r = out.replies[0];
    EXPECT_EQ(r.keyframe, 2);
    ASSERT_EQ(r.points_kf.size(), c.points) << c.neighbours;
    // Keyframe 3's first point, in keyframe 2's frame.
    const Point2 want = reg::Apply(reg::Between(pose(2), pose(3)), point(3, 0));
    const bool found = std::any_of(r.points_kf.begin(), r.points_kf.end(), [&](const Point2& p) {
      return std::hypot(p.x_m - want.x_m, p.y_m - want.y_m) < 1e-9;
    });
    EXPECT_TRUE(found) << c.neighbours;
  }
}

TEST(GraphMatcherStage, ReverseGuessAndRestart) {
  GraphMatcherStageOptions o;
  o.robot_id = kA;
  GraphMatcherStage stage(o);
  msgs::ScanRequest req;
  req.header.robot_id = kB;
  req.header.incarnation = 5;
  req.target_robot = kA;
  req.T_requester_target = {10.0, -2.0, 0.3};
  stage.OnScanRequest(req);
  const Pose2* g = msgs::GuessOf(stage.matches(), kB);
  ASSERT_NE(g, nullptr);
  const Pose2 e = reg::Between(reg::Inverse(req.T_requester_target), *g);
  EXPECT_LT(std::hypot(e.x_m, e.y_m), 1e-9);
  EXPECT_FALSE(stage.matches().guesses.at(kB).matched);
  // Not for us, or from ourselves: ignored.
  msgs::ScanRequest other = req;
  other.target_robot = 2;
  other.header.robot_id = 2;
  stage.OnScanRequest(other);
  other = req;
  other.header.robot_id = kA;
  stage.OnScanRequest(other);
  EXPECT_EQ(stage.matches().guesses.size(), 1u);
  // A new incarnation forgets the guess; its map is held, unmatched.
  msgs::FleetHeader h = req.header;
  h.incarnation = 6;
  stage.OnTeammateObjectMap(h, msgs::ObjectMap{});
  EXPECT_EQ(msgs::GuessOf(stage.matches(), kB), nullptr);
  EXPECT_EQ(stage.teammates().count(kB), 1u);
  // Nothing to match against an empty map.
  msgs::TeamStepStats st;
  EXPECT_TRUE(stage.Step(20.0, msgs::ObjectMap{}, 1, &st).empty());
  EXPECT_EQ(st.matches_tried, 0);
  stage.Forget(kB);
  EXPECT_EQ(stage.teammates().count(kB), 0u);
}

// Objects of `map` as another robot holds them: T_other_map applied to every object.
msgs::ObjectMap Moved(const msgs::ObjectMap& map, const Pose2& T_other_map) {
  msgs::ObjectMap out = map;
  for (auto& o : out.objects) {
    o.center = reg::Apply(T_other_map, o.center);
    o.rect_center = reg::Apply(T_other_map, o.rect_center);
    o.yaw_rad = std::fmod(o.yaw_rad + T_other_map.yaw_rad + 4 * std::numbers::pi, std::numbers::pi);
  }
  return out;
}

// A 6 x 3 grid of identical piles 5 m apart, whole in both maps: the votes alone find it
// ambiguous (shifted by a spacing it lays 15 of 18 piles). With vote_miss_weight the stage
// charges every shift for the teammate piles it lays on water where the own keyframes looked
// and returned nothing, and matches; without the own keyframes there is no such evidence.
TEST(GraphMatcherStage, OwnSonarReturnsSettleAGridTheVotesFindAmbiguous) {
  msgs::ObjectMap own;
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 3; ++j) {
      msgs::Object o;
      o.id = static_cast<std::uint32_t>(own.objects.size());
      o.center = o.rect_center = {5.0 * i + 0.05 * ((i * 7 + j * 3) % 5 - 2), 5.0 * j};
      o.length_m = o.breadth_m = 0.6;
      o.num_points = 40;
      own.objects.push_back(o);
    }
  }
  own.map_heading_rad = 0.2;
  const Pose2 T_a_1{12.0, -7.0, 0.4};
  msgs::ObjectMap mate = Moved(own, reg::Inverse(T_a_1));
  mate.map_heading_rad = 0.2 + 0.4 + 0.02;
  const auto run = [&](bool evidence, bool keyframes) {
    GraphMatcherStageOptions o;
    o.robot_id = kA;
    o.match_period_s = 0.0;
    o.matcher.landmarks = false;
    o.matcher.min_assignments = 100;  // no spectral answer: the votes alone
    o.matcher.vote_miss_weight = evidence ? 2.0 : 0.0;
    o.coverage.range_m = 30.0;
    GraphMatcherStage stage(o);
    if (keyframes) {
      // Keyframes along y = -10 m looking north, each returning ten points on every pile.
      msgs::KeyframeTrajectory traj;
      int k = 0;
      for (double x = -15.0; x <= 40.0; x += 2.5, ++k) {
        msgs::Keyframe kf;
        kf.index = k;
        kf.time_s = k;
        kf.T_odom_body = {x, -10.0, std::numbers::pi / 2};
        const Pose2 T_body_map = reg::Inverse(kf.T_odom_body);
        for (const auto& ob : own.objects) {
          for (int n = 0; n < 10; ++n) {
            const double t = 2.0 * std::numbers::pi * n / 10.0;
            kf.points_body.push_back(reg::Apply(T_body_map, {ob.center.x_m + 0.3 * std::cos(t),
                                                             ob.center.y_m + 0.3 * std::sin(t)}));
          }
        }
        stage.OnKeyframe(kf);
        traj.keyframes.push_back({k, double(k), kf.T_odom_body});
      }
      stage.OnTrajectory(traj);
    }
    msgs::FleetHeader h;
    h.robot_id = 1;
    stage.OnTeammateObjectMap(h, mate);
    msgs::TeamStepStats st;
    stage.Step(10.0, own, 1, &st);
    const auto& g = stage.matches().guesses.at(1);
    return std::pair{g.matched, g.match.T_a_b};
  };
  EXPECT_FALSE(run(false, true).first);  // off: ambiguous
  EXPECT_FALSE(run(true, false).first);  // no own keyframes: no evidence
  const auto [matched, T] = run(true, true);
  ASSERT_TRUE(matched);
  const Pose2 e = reg::Between(T_a_1, T);
  EXPECT_LT(std::hypot(e.x_m, e.y_m), 0.5);
  EXPECT_LT(std::abs(e.yaw_rad), 0.02);
}

TEST(GraphMatcherStage, ChainsAnUnmatchedTeammateThroughASharedEstimate) {
  // Own map: 10 rectangles of distinct sizes, scattered.
  msgs::ObjectMap own;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (std::uint32_t i = 0; i < 10; ++i) {
    msgs::Object o;
    o.id = 100 + i;
    o.center = o.rect_center = {80.0 * u(rng), 80.0 * u(rng)};
    o.length_m = 2.0 + 8.0 * u(rng);
    o.breadth_m = 0.5 + 1.5 * u(rng);
    o.yaw_rad = std::numbers::pi * u(rng);
    o.num_points = 100;
    o.keyframes = {static_cast<int>(i)};
    own.objects.push_back(o);
  }
  const Pose2 T_a_1{12.0, -7.0, 0.4}, T_a_2{-30.0, 25.0, -1.1};
  // Teammate 1 holds the same objects in its frame; teammate 2 only two, one of them own
  // object 103 seen from the other side (its centre 1.5 m off), the other far from anything.
  const msgs::ObjectMap map1 = Moved(own, reg::Inverse(T_a_1));
  msgs::ObjectMap seen2;
  seen2.objects = {own.objects[3]};
  seen2.objects[0].id = 7;
  seen2.objects[0].center.x_m += 1.5;
  seen2.objects[0].rect_center.x_m += 1.5;
  msgs::Object far = own.objects[5];
  far.id = 8;
  far.center = far.rect_center = {300.0, 300.0};
  seen2.objects.push_back(far);
  const msgs::ObjectMap map2 = Moved(seen2, reg::Inverse(T_a_2));

  GraphMatcherStageOptions o;
  o.robot_id = kA;
  o.match_period_s = 0.0;
  GraphMatcherStage stage(o);
  msgs::FleetHeader h1, h2;
  h1.robot_id = 1;
  h2.robot_id = 2;
  stage.OnTeammateObjectMap(h1, map1);
  stage.OnTeammateObjectMap(h2, map2);
  msgs::TeamStepStats st;
  auto requests = stage.Step(10.0, own, 1, &st);
  // Teammate 1 matches; teammate 2 (two objects) does not, and nothing chains it yet.
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].target_robot, 1);
  ASSERT_TRUE(stage.matches().guesses.at(1).matched);
  EXPECT_EQ(msgs::GuessOf(stage.matches(), 2), nullptr);

  // Teammate 1 verified teammate 2 and shares T_1_2 in its heartbeats. Both links must repeat
  // (chain_min_agreeing 3): the own match of 1 and the shared estimate. A first heartbeat
  // with another value, then the true one: still not steady after two more.
  msgs::TeammateTransforms shared;
  shared.header = h1;
  const Pose2 T_1_2 = reg::Compose(reg::Inverse(T_a_1), T_a_2);
  shared.transforms = {{2, Pose2{T_1_2.x_m + 20.0, T_1_2.y_m, T_1_2.yaw_rad}},
                       {kA, Pose2{}}};  // an estimate of ourselves: ignored
  auto has_request_to_2 = [](const std::vector<msgs::ScanRequest>& rs) {
    for (const auto& r : rs) {
      if (r.target_robot == 2) return true;
    }
    return false;
  };
  double t = 20.0;
  stage.OnTeammateTransforms(shared);
  shared.transforms[0].T_sender_robot = T_1_2;
  for (int k = 0; k < 2; ++k, t += 10.0) {
    stage.OnTeammateTransforms(shared);
    stage.OnTeammateObjectMap(h1, map1);  // changed: matched again
    stage.OnTeammateObjectMap(h2, map2);
    EXPECT_FALSE(has_request_to_2(stage.Step(t, own, 1, &st))) << k;
  }
  stage.OnTeammateTransforms(shared);  // the third steady heartbeat
  stage.OnTeammateObjectMap(h2, map2);
  requests = stage.Step(t, own, 1, &st);
  const msgs::ScanRequest* to2 = nullptr;
  for (const auto& r : requests) {
    if (r.target_robot == 2) to2 = &r;
  }
  ASSERT_NE(to2, nullptr);
  const Pose2 e = reg::Between(T_a_2, to2->T_requester_target);
  EXPECT_LT(std::hypot(e.x_m, e.y_m), 1e-3);
  EXPECT_LT(std::abs(e.yaw_rad), 1e-4);
  EXPECT_EQ(to2->object_ids, std::vector<std::uint32_t>{7u});  // the far one has no partner
  const auto& g = stage.matches().guesses.at(2);
  EXPECT_TRUE(g.chained);
  EXPECT_EQ(g.chained_via, 1);
  ASSERT_NE(msgs::GuessOf(stage.matches(), 2), nullptr);
  // Teammate 2 restarts (a new map frame): 1's estimate of the old one is stale, so its map
  // is not chained again until 1 has repeated an estimate three times.
  stage.Forget(2);
  stage.OnTeammateObjectMap(h2, map2);
  t += 10.0;
  stage.OnTeammateTransforms(shared);
  EXPECT_FALSE(has_request_to_2(stage.Step(t, own, 1, &st)));
  EXPECT_EQ(msgs::GuessOf(stage.matches(), 2), nullptr);
  // Teammate 1 restarts: what it shared is forgotten, teammate 2 is not placed any more.
  stage.Forget(1);
  stage.Step(t + 10.0, own, 1, &st);
  EXPECT_EQ(msgs::GuessOf(stage.matches(), 2), nullptr);
}

// A's filter stage fed A's trajectory and B's full keyframe poses (as B's link would hand
// them); returns the header B's messages carry.
msgs::FleetHeader FeedOwnAndTeammatePoses(const Mission& run, ConsistencyStage* stage) {
  msgs::KeyframeTrajectory traj;
  for (const auto& k : run.a.keyframes)
    traj.keyframes.push_back({k.index, k.time_s, k.T_odom_body});
  stage->OnTrajectory(traj);
  msgs::KeyframePoses poses;
  poses.header.robot_id = kB;
  poses.header.incarnation = run.b.incarnation;
  poses.full = true;
  for (const auto& k : run.b.keyframes) {
    poses.poses.push_back(
        {k.index, k.time_s, k.T_odom_body, static_cast<int>(k.points_body.size())});
  }
  stage->OnKeyframePoses(poses);
  return poses.header;
}

// A's registrations of B's scans, as the exchange gave them (ids and flags cleared), to replay
// into a fresh filter.
std::vector<msgs::InterRobotLoop> RegisteredByA(const Mission& run) {
  std::vector<msgs::InterRobotLoop> registered;
  for (auto l : run.agent_a->consistency().candidates()) {
    if (l.own_robot != kA) continue;
    l.id = 0;
    l.flags = 0;
    registered.push_back(l);
  }
  return registered;
}

TEST(ConsistencyStage, NumbersCandidatesAndSendsAcceptedOnce) {
  Mission run;
  Simulate(&run);
  // A's registrations of B's scans, replayed into a fresh filter with A's trajectory, B's
  // poses and A's final guess.
  const std::vector<msgs::InterRobotLoop> registered = RegisteredByA(run);
  ASSERT_GE(registered.size(), 5u);
  ConsistencyStage stage(TeamAgent::ConsistencyOptions(Options(kA)));
  FeedOwnAndTeammatePoses(run, &stage);
  const msgs::MapMatches& matches = run.agent_a->matcher().matches();
  msgs::TeamStepStats st;
  const auto sent = stage.Step(100.0, registered, matches, &st);
  EXPECT_EQ(st.candidates_added, static_cast<int>(registered.size()));
  ASSERT_EQ(stage.candidates().size(), registered.size());
  for (std::size_t i = 0; i < registered.size(); ++i) {
    EXPECT_EQ(stage.candidates()[i].id, i);  // numbered in order from 0
  }
  EXPECT_EQ(st.loops_accepted, static_cast<int>(stage.accepted().size()));
  EXPECT_GE(stage.accepted().size(), 5u);
  ASSERT_EQ(sent.size(), 1u);  // one message to B with every accepted loop
  EXPECT_EQ(sent[0].target_robot, kB);
  EXPECT_EQ(sent[0].loops.size(), stage.accepted().size());
  for (const auto& l : sent[0].loops) EXPECT_EQ(l.flags, msgs::kLoopAccepted);
  // Nothing new: nothing sent again.
  msgs::TeamStepStats st2;
  EXPECT_TRUE(stage.Step(101.0, {}, matches, &st2).empty());
  EXPECT_EQ(st2.candidates_added, 0);
  // A restart of B drops its candidates.
  stage.Forget(kB);
  EXPECT_TRUE(stage.candidates().empty());
}

TEST(ConsistencyStage, LoopsReceivedFromATeammateAreCapped) {
  Mission run;
  Simulate(&run);
  // B's registrations of A's scans, as B would send them to A; A's stage takes at most 3.
  std::vector<msgs::InterRobotLoop> theirs;
  for (auto l : run.agent_b->consistency().candidates()) {
    if (l.own_robot == kB && l.teammate_robot == kA) theirs.push_back(l);
  }
  ASSERT_GE(theirs.size(), 5u);
  auto options = TeamAgent::ConsistencyOptions(Options(kA));
  options.max_received_loops_per_teammate = 3;
  ConsistencyStage stage(options);
  const msgs::FleetHeader header = FeedOwnAndTeammatePoses(run, &stage);
  msgs::LoopClosureMessage message;
  message.header = header;
  message.target_robot = kA;
  message.loops = theirs;
  stage.OnLoopClosures(message);
  msgs::TeamStepStats st;
  stage.Step(100.0, {}, run.agent_a->matcher().matches(), &st);
  EXPECT_EQ(stage.candidates().size(), 3u);
  EXPECT_EQ(stage.teammates().at(kB).ignored, static_cast<int>(theirs.size()) - 3);
}

// max_accepted_per_teammate_keyframe: once A's registrations are decided, a new candidate
// naming a teammate keyframe j with K accepted loops (registered from another own keyframe,
// consistent with them) is dropped and counted at the bound K, taken at K + 1 and with the
// bound off.
TEST(ConsistencyStage, CandidatesAtWellSupportedTeammateKeyframesAreRedundant) {
  Mission run;
  Simulate(&run);
  const std::vector<msgs::InterRobotLoop> registered = RegisteredByA(run);
  const auto pose_of = [&](int index) {
    for (const auto& k : run.a.keyframes) {
      if (k.index == index) return std::optional<Pose2>(k.T_odom_body);
    }
    return std::optional<Pose2>();
  };
  for (const int bound_offset : {-1, 0, 1}) {  // off, K, K + 1
    auto options = TeamAgent::ConsistencyOptions(Options(kA));
    ConsistencyStage stage(options);
    FeedOwnAndTeammatePoses(run, &stage);
    const msgs::MapMatches& matches = run.agent_a->matcher().matches();
    msgs::TeamStepStats st;
    stage.Step(100.0, registered, matches, &st);
    const auto accepted = stage.accepted();
    ASSERT_GE(accepted.size(), 5u);
    const auto& l = accepted.front();
    int k_accepted = 0;
    std::set<int> own_at_j;
    for (const auto& c : stage.candidates()) {
      if (c.teammate_keyframe != l.teammate_keyframe) continue;
      own_at_j.insert(c.own_keyframe);
      k_accepted += (c.flags & msgs::kLoopAccepted) ? 1 : 0;
    }
    // The same teammate scan seen from an own keyframe not yet paired with it.
    int other = -1;
    for (const auto& k : run.a.keyframes) {
      if (!own_at_j.count(k.index)) {
        other = k.index;
        break;
      }
    }
    ASSERT_GE(other, 0);
    auto extra = l;
    extra.id = 0;
    extra.flags = 0;
    extra.own_keyframe = other;
    extra.T_ownkf_teammatekf =
        reg::Compose(reg::Between(*pose_of(other), *pose_of(l.own_keyframe)), l.T_ownkf_teammatekf);
    // The bound is an option of the stage: a second stage with it, fed the same first step.
    options.max_accepted_per_teammate_keyframe = bound_offset < 0 ? 0 : k_accepted + bound_offset;
    ConsistencyStage bounded(options);
    FeedOwnAndTeammatePoses(run, &bounded);
    bounded.Step(100.0, registered, matches, &st);
    bounded.Step(101.0, {extra}, matches, &st);
    const bool dropped = bound_offset == 0;
    EXPECT_EQ(st.candidates_added, dropped ? 0 : 1) << bound_offset;
    EXPECT_EQ(bounded.candidates().size(), registered.size() + (dropped ? 0 : 1)) << bound_offset;
    EXPECT_EQ(bounded.teammates().at(kB).redundant, dropped ? 1 : 0) << bound_offset;
  }
}

// max_candidates_per_teammate_keyframe: A's registrations of B's scans; at a bound one below
// the most candidates any teammate keyframe has, A holds the first `bound` of each teammate
// keyframe's candidates in arrival order and counts the others; off, it holds them all;
// after B is forgotten its keyframes hold none.
TEST(ConsistencyStage, CandidatesHeldPerTeammateKeyframeAreBounded) {
  Mission run;
  Simulate(&run);
  const std::vector<msgs::InterRobotLoop> registered = RegisteredByA(run);
  std::map<int, int> per_keyframe;
  for (const auto& l : registered) ++per_keyframe[l.teammate_keyframe];
  int most = 0;
  for (const auto& [k, n] : per_keyframe) most = std::max(most, n);
  ASSERT_GE(most, 2);
  const int bound = most - 1;
  std::vector<std::pair<int, int>> expected;  // (own, teammate keyframe) kept, in order
  std::map<int, int> taken;
  for (const auto& l : registered) {
    if (taken[l.teammate_keyframe]++ < bound) {
      expected.emplace_back(l.own_keyframe, l.teammate_keyframe);
    }
  }
  ASSERT_LT(expected.size(), registered.size());
  for (const int k_max : {0, bound}) {
    auto options = TeamAgent::ConsistencyOptions(Options(kA));
    options.max_accepted_per_teammate_keyframe = 0;
    options.max_candidates_per_teammate_keyframe = k_max;
    ConsistencyStage stage(options);
    FeedOwnAndTeammatePoses(run, &stage);
    msgs::TeamStepStats st;
    // Two steps: the bound counts what earlier steps hold.
    const std::size_t half = registered.size() / 2;
    stage.Step(100.0, {registered.begin(), registered.begin() + half},
               run.agent_a->matcher().matches(), &st);
    stage.Step(101.0, {registered.begin() + half, registered.end()},
               run.agent_a->matcher().matches(), &st);
    if (k_max == 0) {
      EXPECT_EQ(stage.candidates().size(), registered.size());
      EXPECT_EQ(stage.teammates().at(kB).crowded, 0);
      continue;
    }
    ASSERT_EQ(stage.candidates().size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
      EXPECT_EQ(stage.candidates()[i].own_keyframe, expected[i].first) << i;
      EXPECT_EQ(stage.candidates()[i].teammate_keyframe, expected[i].second) << i;
    }
    EXPECT_EQ(stage.teammates().at(kB).crowded,
              static_cast<int>(registered.size() - expected.size()));
    stage.Forget(kB);
    EXPECT_TRUE(stage.candidates().empty());
  }
}

// max_candidates_per_teammate: A's registrations of B's scans over two steps; A holds the
// first 4 and counts the others; B's restart frees its share.
TEST(ConsistencyStage, CandidatesHeldPerTeammateAreBounded) {
  Mission run;
  Simulate(&run);
  const std::vector<msgs::InterRobotLoop> registered = RegisteredByA(run);
  ASSERT_GE(registered.size(), 7u);
  auto options = TeamAgent::ConsistencyOptions(Options(kA));
  options.max_candidates_per_teammate = 4;
  ConsistencyStage stage(options);
  const msgs::FleetHeader header = FeedOwnAndTeammatePoses(run, &stage);
  const msgs::MapMatches& matches = run.agent_a->matcher().matches();
  const std::vector<msgs::InterRobotLoop> first(registered.begin(), registered.begin() + 3);
  const std::vector<msgs::InterRobotLoop> rest(registered.begin() + 3, registered.end());
  msgs::TeamStepStats st;
  stage.Step(100.0, first, matches, &st);
  EXPECT_EQ(st.candidates_added, 3);
  stage.Step(101.0, rest, matches, &st);
  EXPECT_EQ(st.candidates_added, 1);
  ASSERT_EQ(stage.candidates().size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(stage.candidates()[i].own_keyframe, registered[i].own_keyframe);
    EXPECT_EQ(stage.candidates()[i].teammate_keyframe, registered[i].teammate_keyframe);
  }
  EXPECT_EQ(stage.teammates().at(kB).over_bound, static_cast<int>(registered.size()) - 4);
  stage.Forget(kB);
  EXPECT_TRUE(stage.candidates().empty());
  msgs::KeyframePoses again;
  again.header = header;
  again.header.incarnation = header.incarnation + 1;
  again.full = true;
  for (const auto& k : run.b.keyframes) {
    again.poses.push_back(
        {k.index, k.time_s, k.T_odom_body, static_cast<int>(k.points_body.size())});
  }
  stage.OnKeyframePoses(again);
  stage.Step(102.0, rest, matches, &st);
  EXPECT_EQ(st.candidates_added, 4);
}

}  // namespace
}  // namespace draco::agent
