// Runtime adapter team.Agent: one robot's inter-robot SLAM (TeamAgent) between its local SLAM
// and its fleet link. Writes, on Stop, every robot's trajectory in the own map frame
// (<prefix>team.<robot>.tum), the inter-robot loops (<prefix>inter_loops.csv), the own object
// map (<prefix>objects.csv) and the per-step work (<prefix>agent_steps.csv).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <set>
#include <string>

#include "draco/agent/team_agent.hpp"
#include "draco/graph/component.hpp"
#include "draco/graph/executor.hpp"
#include "draco/msgs/fleet.hpp"
#include "draco/msgs/map.hpp"

namespace draco::agent {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;

class AgentComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "One robot's inter-robot SLAM: object map, object-graph matching, scan requests, "
        "sliding-window registration, GCM/PCM, two-step PGO; talks to teammates through "
        "fleet.Link.");
    keyframe_ = spec.Input<msgs::Keyframe>("keyframe", {.depth = 1024, .doc = "own keyframes"});
    trajectory_ = spec.Input<msgs::KeyframeTrajectory>(
        "trajectory", {.delivery = graph::Delivery::kLatest, .doc = "own optimised keyframes"});
    incoming_ = spec.Input<msgs::FleetIncoming>(
        "incoming", {.depth = 256, .delayed = true, .doc = "teammate messages from the link"});
    outgoing_ = spec.Output<msgs::FleetOutgoing>("outgoing", "what to send, every step");
    spec.Timer("step", 1.0, "one agent step every second of mission time");
    spec.Param("robot_id", &o_.robot_id, {.doc = "own robot id", .min = 0, .max = 63});
    spec.Param("team_names", &team_names_,
               {.doc = "robot names by id (output file names): alpha, bravo, ..."});
    spec.Param("prefix", &prefix_, {.doc = "output file name prefix, e.g. the robot name"});
    spec.Param("method", &method_, {.doc = "consistency filter", .choices = {"gcm", "pcm"}});
    spec.Param("min_clique_size", &o_.filter.min_clique_size,
               {.doc = "minimum consistent set", .min = 1});
    spec.Param("window", &o_.registration.window,
               {.doc = "registration window (keyframes each side)", .min = 0, .max = 20});
    spec.Param("min_overlap", &o_.registration.min_overlap,
               {.doc = "registration acceptance (overlap ratio)", .min = 0.0, .max = 1.0});
    spec.Param("candidate_radius_m", &o_.selection.candidate_radius_m,
               {.doc = "own keyframes this close to a placed teammate scan are candidates",
                .unit = "m",
                .min = 0.0});
    spec.Param("candidate_max_yaw_rad", &o_.selection.candidate_max_yaw_rad,
               {.doc = "... and within this heading difference", .unit = "rad", .min = 0.0});
    spec.Param("object_map_period_s", &o_.object_map_period_s,
               {.doc = "own object map published at most this often", .unit = "s", .min = 0.0});
    spec.Param("match_period_s", &o_.match_period_s,
               {.doc = "a teammate map matched at most this often", .unit = "s", .min = 0.0});
    spec.Param("optimize_period_s", &o_.optimize_period_s,
               {.doc = "two-step PGO at most this often", .unit = "s", .min = 0.0});
    spec.Param("place_unverified_teammates", &o_.place_unverified_teammates,
               {.doc = "place teammates by the map-to-map guess before any loop is accepted"});
    spec.Param("map_sigma_m", &o_.map_sigma_m,
               {.doc = "map-to-map guess sigma in GCM", .unit = "m", .min = 0.0});
    spec.Param("map_sigma_rad", &o_.map_sigma_rad,
               {.doc = "map-to-map guess sigma in GCM", .unit = "rad", .min = 0.0});
  }

  Status Start(Context&) override {
    o_.filter.method = method_ == "pcm" ? consistency::Method::kPcm : consistency::Method::kGcm;
    o_.filter.time_budget_ms = 0.0;  // answers must not depend on machine load
    agent_ = std::make_unique<TeamAgent>(o_);
    return Status::Ok();
  }

  Status Process(Context& ctx) override {
    for (const auto& k : keyframe_.TakeAll()) agent_->OnKeyframe(*k.value);
    if (auto t = trajectory_.Take()) agent_->OnTrajectory(*t->value);
    for (const auto& m : incoming_.TakeAll()) Feed(*m.value);
    if (ctx.reason() != graph::Reason::kTimer) return Status::Ok();
    const double now_s = ctx.Now().Seconds();
    Outbox box = agent_->Step(now_s);
    msgs::FleetOutgoing out;
    out.time_s = now_s;
    out.has_object_map = box.has_object_map;
    out.object_map = std::move(box.object_map);
    out.has_poses = !box.poses.empty();
    out.poses = std::move(box.poses);
    out.requests = std::move(box.requests);
    out.replies = std::move(box.replies);
    out.loops = std::move(box.loops);
    if (out.has_object_map || out.has_poses || !out.requests.empty() || !out.replies.empty() ||
        !out.loops.empty()) {
      outgoing_.PublishAt(ctx.Now(), std::move(out));
    }
    return Status::Ok();
  }

  Status Stop(Context& ctx) override {
    if (!agent_ || ctx.output_dir().empty()) return Status::Ok();
    const auto dir = std::filesystem::path(ctx.output_dir());
    const auto& est = agent_->estimate();
    std::vector<std::pair<std::string, std::string>> files;
    for (const auto& [id, traj] : est.trajectories) {
      std::string text = "# timestamp x y z qx qy qz qw (robot " + Name(id) +
                         " in the map frame of robot " + Name(o_.robot_id) + ")\n";
      for (const auto& k : traj) {
        char line[200];
        std::snprintf(line, sizeof line, "%.6f %.4f %.4f 0 0 0 %.9f %.9f\n", k.time_s,
                      k.T_map_kf.x_m, k.T_map_kf.y_m, std::sin(0.5 * k.T_map_kf.yaw_rad),
                      std::cos(0.5 * k.T_map_kf.yaw_rad));
        text += line;
      }
      files.push_back({"team." + Name(id) + ".tum", text});
    }
    std::set<std::uint64_t> accepted;
    for (const auto& l : est.accepted) accepted.insert(l.id);
    std::string loops =
        "id,own_robot,own_keyframe,teammate_robot,teammate_keyframe,x_m,y_m,yaw_rad,overlap,"
        "accepted\n";
    for (const auto& l : est.candidates) {
      char line[256];
      std::snprintf(line, sizeof line, "%llu,%d,%d,%d,%d,%.4f,%.4f,%.5f,%.3f,%d\n",
                    static_cast<unsigned long long>(l.id), l.own_robot, l.own_keyframe,
                    l.teammate_robot, l.teammate_keyframe, l.T_ownkf_teammatekf.x_m,
                    l.T_ownkf_teammatekf.y_m, l.T_ownkf_teammatekf.yaw_rad, l.overlap,
                    accepted.count(l.id) ? 1 : 0);
      loops += line;
    }
    files.push_back({"inter_loops.csv", loops});
    std::string objects = "id,center_x_m,center_y_m,length_m,breadth_m,yaw_rad,num_points\n";
    for (const auto& ob : agent_->OwnObjects().objects) {
      char line[200];
      std::snprintf(line, sizeof line, "%u,%.3f,%.3f,%.3f,%.3f,%.4f,%d\n", ob.id, ob.center.x_m,
                    ob.center.y_m, ob.length_m, ob.breadth_m, ob.yaw_rad, ob.num_points);
      objects += line;
    }
    files.push_back({"objects.csv", objects});
    std::string steps =
        "time_s,matches_tried,matches_found,requests_sent,scans_registered,candidates_added,"
        "loops_accepted,optimized,wall_ms\n";
    for (const auto& s : agent_->step_stats()) {
      char line[200];
      std::snprintf(line, sizeof line, "%.3f,%d,%d,%d,%d,%d,%d,%d,%.3f\n", s.time_s,
                    s.matches_tried, s.matches_found, s.requests_sent, s.scans_registered,
                    s.candidates_added, s.loops_accepted, s.optimized ? 1 : 0, s.wall_ms);
      steps += line;
    }
    files.push_back({"agent_steps.csv", steps});
    for (const auto& [name, text] : files) {
      const auto path = (dir / (prefix_ + name)).string();
      if (!graph::WriteFileAtomically(path, text)) return Status::Fatal("cannot write " + path);
    }
    return Status::Ok();
  }

 private:
  std::string Name(int id) const {
    if (id >= 0 && id < static_cast<int>(team_names_.size())) return team_names_[id];
    return "robot" + std::to_string(id);
  }

  void Feed(const msgs::FleetIncoming& in) {
    for (const auto& e : in.events) {
      if (e.kind == msgs::TeammateEventKind::kRestarted) agent_->ForgetTeammate(e.robot_id);
    }
    for (const auto& m : in.object_maps) agent_->OnTeammateObjectMap(m.header, m.map);
    for (const auto& m : in.poses) agent_->OnKeyframePoses(m);
    for (const auto& m : in.requests) agent_->OnScanRequest(m);
    for (const auto& m : in.replies) agent_->OnScanReply(m);
    for (const auto& m : in.loops) agent_->OnLoopClosures(m);
  }

  AgentOptions o_;
  std::vector<std::string> team_names_{"alpha", "bravo", "charlie"};
  std::string prefix_;
  std::string method_ = "gcm";
  std::unique_ptr<TeamAgent> agent_;
  graph::In<msgs::Keyframe> keyframe_;
  graph::In<msgs::KeyframeTrajectory> trajectory_;
  graph::In<msgs::FleetIncoming> incoming_;
  graph::Out<msgs::FleetOutgoing> outgoing_;
};

}  // namespace

DRACO_REGISTER_COMPONENT(AgentComponent, "team.Agent")

}  // namespace draco::agent
