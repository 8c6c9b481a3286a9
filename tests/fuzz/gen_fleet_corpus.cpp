// Writes the seed corpus of fuzz_fleet_codec: what a robot's link endpoint really sends
// (to robot 0, the receiver in fuzz_fleet_codec's link path).
//
// A LinkEndpoint (robot 1 of team {0, 1, 2}) is given a marina-like object map, keyframe
// poses along a lawnmower leg, scan requests and replies, a loop message and map transforms
// over a few ticks, then closes (a goodbye clock frame). Every frame it hands its transport
// is captured: each payload becomes a seed "<kind byte><payload>" and the frames together a
// seed of the link path ("0" then the frames in fuzz_fleet_codec.cpp's LinkFrames layout).
// With UDP_OUT_DIR, the first frame of each kind is also written there as the UDP datagram
// the plain-UDP transport would send (the seeds of fuzz_udp_datagram).
//
//   gen_fleet_corpus OUT_DIR [UDP_OUT_DIR]
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "draco/fleet/link.hpp"
#include "draco/log/log.hpp"
#include "draco/middleware/transport.hpp"

namespace {

using namespace draco;

// An in-process transport that keeps a copy of every frame sent.
class CaptureTransport final : public middleware::Transport {
 public:
  CaptureTransport(std::unique_ptr<middleware::Transport> inner,
                   std::vector<middleware::Frame>* out)
      : inner_(std::move(inner)), out_(out) {}
  bool Send(const middleware::Frame& frame) override {
    out_->push_back(frame);
    return inner_->Send(frame);
  }
  std::vector<middleware::Frame> Receive() override { return inner_->Receive(); }
  std::string Describe() const override { return "capture:" + inner_->Describe(); }
  middleware::TransportCounters counters() const override { return inner_->counters(); }

 private:
  std::unique_ptr<middleware::Transport> inner_;
  std::vector<middleware::Frame>* out_;
};

msgs::ObjectMap MarinaObjects(double shift_m) {
  msgs::ObjectMap map;
  map.robot_id = 1;
  map.map_heading_rad = 0.31;
  std::uint32_t id = 1;
  for (int bent = 0; bent < 6; ++bent) {  // pier piles
    for (int k = 0; k < 3; ++k) {
      msgs::Object o;
      o.id = id++;
      o.center = {12.0 + 2.4 * bent + shift_m, -4.0 + 1.5 * k};
      o.rect_center = {o.center.x_m + 0.02, o.center.y_m - 0.01};
      o.length_m = 0.45;
      o.breadth_m = 0.3;
      o.yaw_rad = 0.2 * k;
      o.num_points = 14 + bent;
      map.objects.push_back(o);
    }
  }
  msgs::Object boat;  // a moored boat hull
  boat.id = id++;
  boat.center = {-8.5, 21.3};
  boat.rect_center = {-8.4, 21.1};
  boat.length_m = 11.2;
  boat.breadth_m = 3.6;
  boat.yaw_rad = 1.2;
  boat.num_points = 240;
  map.objects.push_back(boat);
  msgs::Object landmark;  // a local-SLAM point landmark
  landmark.id = msgs::kLandmarkIdBit + 3;
  landmark.landmark = true;
  landmark.center = landmark.rect_center = {4.2, -17.9};
  landmark.length_m = landmark.breadth_m = 0.35;
  landmark.num_points = 9;
  map.objects.push_back(landmark);
  return map;
}

std::vector<msgs::KeyframePoseEntry> Keyframes(int n, double drift) {
  std::vector<msgs::KeyframePoseEntry> poses;
  for (int i = 0; i < n; ++i) {
    msgs::KeyframePoseEntry e;
    e.index = i;
    e.time_s = 2.0 * i;
    e.T_map_kf = {0.7 * i + drift * i * i, 0.05 * i, 0.01 * i};
    e.num_points = 180 + (i * 37) % 90;
    poses.push_back(e);
  }
  return poses;
}

msgs::ScanReply Reply(int keyframe) {
  msgs::ScanReply r;
  r.requester_robot = 0;
  r.keyframe = keyframe;
  r.keyframe_time_s = 2.0 * keyframe;
  r.T_map_kf = {0.7 * keyframe, 0.05 * keyframe, 0.01 * keyframe};
  for (int i = 0; i < 120; ++i) {  // a wall seen along an arc and a pile
    const double a = -0.6 + 0.01 * i;
    r.points_kf.push_back({14.0 * std::cos(a), 14.0 * std::sin(a)});
  }
  for (int i = 0; i < 12; ++i) r.points_kf.push_back({6.1 + 0.05 * (i % 3), -2.0 + 0.05 * i});
  return r;
}

void Write(const std::filesystem::path& file, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(file, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2 && argc != 3) {
    std::fprintf(stderr, "usage: gen_fleet_corpus OUT_DIR [UDP_OUT_DIR]\n");
    return 2;
  }
  log::SetLevel(log::Level::kWarn);
  const std::filesystem::path dir = argv[1];
  std::filesystem::create_directories(dir);

  std::vector<middleware::Frame> sent;
  fleet::LinkOptions options;
  options.robot_id = 1;
  options.team = {0, 1, 2};
  options.incarnation = 0x5eed1234;
  fleet::LinkEndpoint link(options, std::make_unique<CaptureTransport>(
                                        middleware::MakeInProcessTransport("gen", 1), &sent));
  // Robot 0 listens and acknowledges (robot 1 sends maps only to known teammates).
  fleet::LinkOptions listener_options = options;
  listener_options.robot_id = 0;
  listener_options.incarnation = 0x0ddba11;
  fleet::LinkEndpoint listener(listener_options, middleware::MakeInProcessTransport("gen", 0));

  for (int tick = 0; tick < 10; ++tick) {
    const double now = 0.5 * tick;
    msgs::FleetOutgoing out;
    out.time_s = now;
    if (tick == 0 || tick == 7) {  // a full map, then a delta (one pile moved, one gone)
      out.has_object_map = true;
      out.object_map = MarinaObjects(tick == 0 ? 0.0 : 0.3);
      if (tick == 7) out.object_map.objects.erase(out.object_map.objects.begin() + 2);
      out.has_poses = true;
      out.poses = Keyframes(tick == 0 ? 6 : 9, tick == 0 ? 0.0 : 0.004);
    }
    if (tick == 2) {
      msgs::ScanRequest req;
      req.target_robot = 0;
      req.object_map_version = 2;
      req.T_requester_target = {3.5, -12.25, 0.42};
      req.object_ids = {4, 17, 9, 1073741827};
      req.max_scans = 8;
      out.requests.push_back(req);
    }
    if (tick == 3) {
      out.replies.push_back(Reply(3));
      out.replies.push_back(Reply(5));
    }
    if (tick == 5) {
      msgs::LoopClosureMessage lm;
      lm.target_robot = 0;
      for (int i = 0; i < 3; ++i) {
        msgs::InterRobotLoop l;
        l.id = 40 + i;
        l.own_robot = 1;
        l.own_keyframe = 3 + i;
        l.teammate_robot = 0;
        l.teammate_keyframe = 11 - i;
        l.T_ownkf_teammatekf = {1.2 - 0.1 * i, -0.4, 0.05 * i};
        l.covariance = {0.04, 0.001, 0.0, 0.001, 0.05, 0.0002, 0.0, 0.0002, 0.0009};
        l.overlap = 0.62 + 0.05 * i;
        l.flags = i == 2 ? 1u : 0u;
        lm.loops.push_back(l);
      }
      out.loops.push_back(lm);
      out.has_transforms = true;
      out.transforms = {{2, {-5.5, 18.25, 1.1}}, {0, {30.0, -2.5, -0.3}}};
    }
    listener.Tick(now, nullptr);
    link.Tick(now, &out);
  }
  for (double now = 5.0; now <= 6.0; now += 0.5) {  // the next heartbeat, with the transforms
    listener.Tick(now, nullptr);
    link.Tick(now, nullptr);
  }
  link.Close(6.5);  // goodbye clock frame

  std::map<int, int> per_kind;
  std::vector<std::uint8_t> frames = {0};  // the link path
  for (std::size_t i = 0; i < sent.size(); ++i) {
    const middleware::Frame& f = sent[i];
    const int n = per_kind[f.kind]++;
    if (argc == 3 && n == 0) {
      std::filesystem::create_directories(argv[2]);
      Write(std::filesystem::path(argv[2]) / ("kind-" + std::to_string(f.kind)),
            middleware::EncodeUdpDatagram(f));
    }
    if (f.kind >= 1 && f.kind <= 6 && n < 3) {
      std::vector<std::uint8_t> seed = {f.kind};
      seed.insert(seed.end(), f.payload.begin(), f.payload.end());
      Write(dir / (std::string(msgs::FleetKindName(static_cast<msgs::FleetKind>(f.kind))) + "-" +
                   std::to_string(n)),
            seed);
    }
    // LinkFrames layout: source, destination, kind, delivered time (0.25 s steps), seq,
    // length. Delivery times spread over the fuzz target's ticks (0 to 1.5 s) in order.
    const std::size_t len = f.payload.size();
    const auto due = static_cast<std::uint8_t>(2 * (4 * i / sent.size()));
    frames.insert(
        frames.end(),
        {1,
         static_cast<std::uint8_t>(f.destination == middleware::kBroadcast ? 0x80 : f.destination),
         f.kind, due, static_cast<std::uint8_t>(f.seq), static_cast<std::uint8_t>(len & 0xff),
         static_cast<std::uint8_t>(len >> 8)});
    frames.insert(frames.end(), f.payload.begin(), f.payload.end());
  }
  Write(dir / "link-frames", frames);
  std::printf("%zu frames captured into %s\n", sent.size(), dir.c_str());
  return 0;
}
