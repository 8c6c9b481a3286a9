// Runtime adapter fleet.Link: a robot's end of the fleet link (LinkEndpoint) over the
// in-process bus (deterministic replay, tests) or Cyclone DDS (one daemon per robot).
#include <filesystem>
#include <memory>
#include <string>

#include "draco/fleet/link.hpp"
#include "draco/graph/component.hpp"
#include "draco/graph/executor.hpp"
#include "draco/middleware/transport.hpp"
#include "draco/msgs/fleet.hpp"

namespace draco::fleet {
namespace {

using graph::Context;
using graph::Spec;
using graph::Status;

class LinkComponent final : public graph::Component {
 public:
  void Declare(Spec& spec) override {
    spec.Doc(
        "A robot's end of the fleet link: compact encoding, object-map and pose deltas, the "
        "acoustic channel model (team budget, latency, loss, turn-taking), teammate liveness "
        "and restarts; in-process bus or Cyclone DDS. Writes <prefix>link_stats.json and "
        "<prefix>link_traffic.csv.");
    outgoing_ = spec.Input<msgs::FleetOutgoing>(
        "outgoing", {.trigger = false, .depth = 256, .doc = "what the team agent wants sent"});
    incoming_ = spec.Output<msgs::FleetIncoming>("incoming", "decoded teammate messages");
    spec.Timer("tick", 0.5, "queue, transmit, receive and deliver every 0.5 s of mission time");
    spec.Param("robot_id", &o_.robot_id, {.doc = "own robot id", .min = 0, .max = 63});
    spec.Param("team", &team_,
               {.doc = "robot ids of the team (own included)", .min = 0, .max = 63});
    spec.Param("transport", &transport_, {.doc = "link transport", .choices = {"inproc", "dds"}});
    spec.Param("bus", &bus_, {.doc = "in-process bus name (transport inproc)"});
    spec.Param("domain_id", &domain_id_,
               {.doc = "DDS domain (transport dds)", .min = 0, .max = 230});
    spec.Param("dds_config", &dds_config_,
               {.doc = "Cyclone DDS XML configuration file; empty: $CYCLONEDDS_URI or defaults"});
    spec.Param("lockstep", &o_.lockstep,
               {.doc = "replay in step with the teammates' mission clocks (DDS replays)"});
    spec.Param("lockstep_timeout_s", &o_.lockstep_timeout_s,
               {.doc = "wall time to wait for a lagging teammate", .unit = "s", .min = 0.0});
    spec.Param("startup_timeout_s", &o_.startup_timeout_s,
               {.doc = "wall time to discover the teammates", .unit = "s", .min = 0.0});
    spec.Param("team_rate_bps", &o_.channel.team_rate_bps,
               {.doc = "acoustic modem budget of the whole team", .unit = "bit/s", .min = 1.0});
    spec.Param("latency_s", &o_.channel.latency_s,
               {.doc = "delay after a frame's last bit", .unit = "s", .min = 0.0});
    spec.Param("loss_probability", &o_.channel.loss_probability,
               {.doc = "probability a frame is lost", .min = 0.0, .max = 1.0});
    spec.Param("tdma", &o_.channel.tdma, {.doc = "half-duplex turn-taking (round-robin slots)"});
    spec.Param("slot_s", &o_.channel.slot_s, {.doc = "turn-taking slot", .unit = "s", .min = 0.01});
    spec.Param("max_wait_s", &o_.channel.max_wait_s,
               {.doc = "a frame queued longer is dropped", .unit = "s", .min = 0.0});
    spec.Param("heartbeat_period_s", &o_.heartbeat_period_s,
               {.doc = "heartbeat period", .unit = "s", .min = 0.5});
    spec.Param("silence_s", &o_.silence_s,
               {.doc = "a teammate unheard for this long is silent", .unit = "s", .min = 1.0});
    spec.Param("prefix", &prefix_, {.doc = "output file name prefix, e.g. the robot name"});
  }

  Status Start(Context&) override {
    o_.team = team_;
    o_.channel.team_size = static_cast<int>(team_.size());
    if (o_.channel.team_size < 1) return Status::Fatal("team: at least one robot id");
    bool own = false;
    for (int id : team_) own = own || id == o_.robot_id;
    if (!own) {
      return Status::Fatal("team does not contain robot_id " + std::to_string(o_.robot_id));
    }
    try {
      std::unique_ptr<middleware::Transport> transport;
      if (transport_ == "dds") {
        middleware::DdsOptions d;
        d.domain_id = domain_id_;
        d.robot_id = static_cast<std::uint16_t>(o_.robot_id);
        d.config_file = dds_config_;
        transport = middleware::MakeDdsTransport(d);
      } else {
        transport =
            middleware::MakeInProcessTransport(bus_, static_cast<std::uint16_t>(o_.robot_id));
      }
      link_ = std::make_unique<LinkEndpoint>(o_, std::move(transport));
    } catch (const std::exception& e) {
      return Status::Fatal(e.what());
    }
    return Status::Ok();
  }

  Status Process(Context& ctx) override {
    // Merge what queued since the last tick: the newest map and poses, every request, reply
    // and loop message.
    msgs::FleetOutgoing merged;
    bool any = false;
    for (const auto& m : outgoing_.TakeAll()) {
      any = true;
      const auto& out = *m.value;
      merged.time_s = out.time_s;
      if (out.has_object_map) {
        merged.has_object_map = true;
        merged.object_map = out.object_map;
      }
      if (out.has_poses) {
        merged.has_poses = true;
        merged.poses = out.poses;
      }
      merged.requests.insert(merged.requests.end(), out.requests.begin(), out.requests.end());
      merged.replies.insert(merged.replies.end(), out.replies.begin(), out.replies.end());
      merged.loops.insert(merged.loops.end(), out.loops.begin(), out.loops.end());
    }
    const double now_s = ctx.Now().Seconds();
    last_s_ = now_s;
    auto in = link_->Tick(now_s, any ? &merged : nullptr, [&ctx] { return ctx.StopRequested(); });
    if (!in.empty()) incoming_.PublishAt(ctx.Now(), std::move(in));
    return Status::Ok();
  }

  Status Stop(Context& ctx) override {
    if (!link_) return Status::Ok();
    link_->Close(last_s_);
    if (ctx.output_dir().empty()) return Status::Ok();
    const auto dir = std::filesystem::path(ctx.output_dir());
    std::vector<std::string> names(middleware::kMaxKinds);
    for (int k = 1; k < msgs::kNumFleetKinds; ++k) {
      names[k] = msgs::FleetKindName(static_cast<msgs::FleetKind>(k));
    }
    for (const auto& [name, text] :
         {std::pair<std::string, std::string>{"link_stats.json", link_->StatsJson()},
          {"link_traffic.csv", middleware::TrafficCsv(link_->stats(), names)}}) {
      const auto path = (dir / (prefix_ + name)).string();
      if (!graph::WriteFileAtomically(path, text)) return Status::Fatal("cannot write " + path);
    }
    return Status::Ok();
  }

 private:
  LinkOptions o_;
  std::vector<int> team_{0, 1, 2};
  std::string transport_ = "inproc";
  std::string bus_ = "team";
  int domain_id_ = 0;
  std::string dds_config_;
  std::string prefix_;
  double last_s_ = 0.0;
  std::unique_ptr<LinkEndpoint> link_;
  graph::In<msgs::FleetOutgoing> outgoing_;
  graph::Out<msgs::FleetIncoming> incoming_;
};

}  // namespace

DRACO_REGISTER_COMPONENT(LinkComponent, "fleet.Link")

}  // namespace draco::fleet
