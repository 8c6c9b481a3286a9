// Runtime adapter fleet.Link: a robot's end of the fleet link (LinkEndpoint) over the
// in-process bus (deterministic replay, tests), Cyclone DDS (one daemon per robot) or plain UDP
// to static peers (a slow acoustic modem: no discovery traffic).
// One input per kind of message to send and one output per kind of message received, so the
// team stages (components/agent) wire to exactly what they send and use.
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
        "and restarts; in-process bus, Cyclone DDS or plain UDP to static peers. Writes "
        "<prefix>link_stats.json and "
        "<prefix>link_traffic.csv.");
    const auto send = [](const char* doc) {
      return graph::InputOptions{.trigger = false, .depth = 4096, .required = false, .doc = doc};
    };
    object_map_ = spec.Input<msgs::ObjectMap>(
        "object_map", send("own object map to send (full; the newest is sent as a delta)"));
    poses_ = spec.Input<msgs::KeyframePoses>(
        "keyframe_poses", send("every own keyframe pose (the newest is sent as an update)"));
    requests_ = spec.Input<msgs::ScanRequest>("scan_requests", send("scan requests to send"));
    replies_ = spec.Input<msgs::ScanReply>("scan_replies", send("scans to send"));
    loops_ = spec.Input<msgs::LoopClosureMessage>("loop_closures", send("accepted loops to send"));
    transforms_ = spec.Input<msgs::MapTransforms>(
        "map_transforms", send("own verified map-to-map estimates (sent with heartbeats)"));
    events_ = spec.Output<msgs::TeammateEvent>("teammate_events",
                                               "a teammate joined, restarted, went silent or left");
    maps_out_ = spec.Output<msgs::TeammateObjectMap>(
        "teammate_object_maps", "a teammate's object map after an update was applied");
    poses_out_ =
        spec.Output<msgs::KeyframePoses>("teammate_keyframe_poses", "a teammate's keyframe poses");
    requests_out_ =
        spec.Output<msgs::ScanRequest>("teammate_scan_requests", "scan requests for us");
    replies_out_ = spec.Output<msgs::ScanReply>("teammate_scan_replies", "scans for our requests");
    loops_out_ = spec.Output<msgs::LoopClosureMessage>("teammate_loop_closures",
                                                       "loops teammates accepted with us");
    transforms_out_ = spec.Output<msgs::TeammateTransforms>(
        "teammate_map_transforms", "a teammate's verified map-to-map estimates");
    spec.Timer("tick", 0.5, "queue, transmit, receive and deliver every 0.5 s of mission time");
    spec.Param("robot_id", &o_.robot_id, {.doc = "own robot id", .min = 0, .max = 63});
    spec.Param("team", &team_,
               {.doc = "robot ids of the team (own included)", .min = 0, .max = 63});
    spec.Param("transport", &transport_,
               {.doc = "link transport", .choices = {"inproc", "dds", "udp"}});
    spec.Param("bus", &bus_, {.doc = "in-process bus name (transport inproc)"});
    spec.Param("domain_id", &domain_id_,
               {.doc = "DDS domain (transport dds)", .min = 0, .max = 230});
    spec.Param("dds_config", &dds_config_,
               {.doc = "Cyclone DDS XML configuration file; empty: $CYCLONEDDS_URI or defaults"});
    spec.Param("dds_topic_prefix", &dds_.topic_prefix,
               {.doc = "prepended to the DDS topic 'draco_link' (letters, digits, '_'): teams "
                       "with different prefixes share a domain without hearing each other"});
    spec.Param("dds_reliability", &dds_reliability_,
               {.doc = "DDS reliability of the link topic (the same for the whole team)",
                .choices = {"reliable", "best_effort"}});
    spec.Param("dds_history_depth", &dds_.history_depth,
               {.doc = "DDS keep-last history per robot, frames", .min = 1, .max = 100000});
    spec.Param("dds_liveliness_lease_s", &dds_.liveliness_lease_s,
               {.doc = "DDS liveliness lease of the robot's writer: a teammate whose process or "
                       "network is gone is noticed after it (logged; 0: no lease)",
                .unit = "s",
                .min = 0.0});
    spec.Param("udp_port", &udp_.port,
               {.doc = "UDP port to listen on (transport udp)", .min = 1, .max = 65535});
    spec.Param("udp_bind_address", &udp_.bind_address,
               {.doc = "IPv4 address to listen on (transport udp)"});
    spec.Param("udp_peers", &udp_.peers,
               {.doc = "every teammate as host:port or host (then udp_port), this robot may be "
                       "listed too (transport udp)"});
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
    spec.Param("loss_seed", &loss_seed_,
               {.doc = "which frames loss_probability loses (a hash of seed, source and seq): "
                       "another seed, another draw of the same loss",
                .min = 0});
    spec.Param("tdma", &o_.channel.tdma, {.doc = "half-duplex turn-taking (round-robin slots)"});
    spec.Param("slot_s", &o_.channel.slot_s, {.doc = "turn-taking slot", .unit = "s", .min = 0.01});
    spec.Param("supersede_maps", &o_.supersede_maps,
               {.doc = "a new object-map update replaces an older one still waiting to be sent"});
    spec.Param("max_wait_s", &o_.channel.max_wait_s,
               {.doc = "a frame queued longer is dropped", .unit = "s", .min = 0.0});
    spec.Param("heartbeat_period_s", &o_.heartbeat_period_s,
               {.doc = "heartbeat period", .unit = "s", .min = 0.5});
    spec.Param("heartbeat_max_share", &o_.heartbeat_max_share,
               {.doc = "the team's heartbeats take at most this share of team_rate_bps (the "
                       "period, silence_s and resend times grow on a slow link); 0: fixed period",
                .min = 0.0,
                .max = 1.0});
    spec.Param("silence_s", &o_.silence_s,
               {.doc = "a teammate unheard for this long is silent", .unit = "s", .min = 1.0});
    spec.Param("prefix", &prefix_, {.doc = "output file name prefix, e.g. the robot name"});
  }

  // The delivery rule (link.hpp): a frame sent in a tick at t is handed out at the earliest
  // at t + tick_s / 2, whatever the channel; a microsecond less covers rounding.
  std::optional<graph::Time> CrossIslandDelay() const override {
    return graph::Time::FromSeconds(o_.tick_s / 2.0 - 1e-6);
  }

  Status Start(Context&) override {
    o_.team = team_;
    o_.channel.loss_seed = static_cast<std::uint64_t>(loss_seed_);
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
        middleware::DdsOptions d = dds_;
        d.domain_id = domain_id_;
        d.robot_id = static_cast<std::uint16_t>(o_.robot_id);
        d.config_file = dds_config_;
        d.reliability = middleware::ParseDdsReliability(dds_reliability_);
        transport = middleware::MakeDdsTransport(d);
      } else if (transport_ == "udp") {
        middleware::UdpOptions u = udp_;
        u.robot_id = static_cast<std::uint16_t>(o_.robot_id);
        transport = middleware::MakeUdpTransport(u);
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
    for (const auto& m : object_map_.TakeAll()) {
      any = merged.has_object_map = true;
      merged.object_map = *m;
    }
    for (const auto& m : poses_.TakeAll()) {
      any = merged.has_poses = true;
      merged.poses = m->poses;
    }
    for (const auto& m : requests_.TakeAll()) any = true, merged.requests.push_back(*m);
    for (const auto& m : replies_.TakeAll()) any = true, merged.replies.push_back(*m);
    for (const auto& m : loops_.TakeAll()) any = true, merged.loops.push_back(*m);
    for (const auto& m : transforms_.TakeAll()) {
      any = merged.has_transforms = true;
      merged.transforms = m->transforms;
    }
    const double now_s = ctx.Now().Seconds();
    merged.time_s = now_s;
    last_s_ = now_s;
    auto in = link_->Tick(now_s, any ? &merged : nullptr, [&ctx] { return ctx.StopRequested(); });
    if (const auto lost = link_->transport_counters().peers_lost; lost > peers_lost_) {
      ctx.Log(log::Level::kWarn,
              "DDS: " + std::to_string(lost - peers_lost_) +
                  " teammate writer(s) no longer alive (left, or silent beyond their liveliness "
                  "lease); the link reports the teammate silent after silence_s");
      peers_lost_ = lost;
    }
    // One message per item, kinds in this order (the team stages absorb them in it).
    for (auto& e : in.events) events_.PublishAt(ctx.Now(), e);
    for (auto& m : in.object_maps) maps_out_.PublishAt(ctx.Now(), std::move(m));
    for (auto& m : in.poses) poses_out_.PublishAt(ctx.Now(), std::move(m));
    for (auto& m : in.requests) requests_out_.PublishAt(ctx.Now(), std::move(m));
    for (auto& m : in.replies) replies_out_.PublishAt(ctx.Now(), std::move(m));
    for (auto& m : in.loops) loops_out_.PublishAt(ctx.Now(), std::move(m));
    for (auto& m : in.transforms) transforms_out_.PublishAt(ctx.Now(), std::move(m));
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
  middleware::UdpOptions udp_;
  int loss_seed_ = 1;
  std::string bus_ = "team";
  int domain_id_ = 0;
  std::string dds_config_;
  middleware::DdsOptions dds_;  // topic prefix, history depth, liveliness lease
  std::string dds_reliability_ = "reliable";
  std::uint64_t peers_lost_ = 0;
  std::string prefix_;
  double last_s_ = 0.0;
  std::unique_ptr<LinkEndpoint> link_;
  graph::In<msgs::ObjectMap> object_map_;
  graph::In<msgs::KeyframePoses> poses_;
  graph::In<msgs::ScanRequest> requests_;
  graph::In<msgs::ScanReply> replies_;
  graph::In<msgs::LoopClosureMessage> loops_;
  graph::In<msgs::MapTransforms> transforms_;
  graph::Out<msgs::TeammateEvent> events_;
  graph::Out<msgs::TeammateObjectMap> maps_out_;
  graph::Out<msgs::KeyframePoses> poses_out_;
  graph::Out<msgs::ScanRequest> requests_out_;
  graph::Out<msgs::ScanReply> replies_out_;
  graph::Out<msgs::LoopClosureMessage> loops_out_;
  graph::Out<msgs::TeammateTransforms> transforms_out_;
};

}  // namespace

DRACO_REGISTER_COMPONENT(LinkComponent, "fleet.Link")

}  // namespace draco::fleet
