// Messages robots send each other over the fleet link (issue 7, docs/fleet.md). Plain structs,
// SI units in names, mission times in seconds. What crosses the link is their compact
// encoding (components/fleet: codec.hpp), never these structs.
//
// Robot ids are small integers (mission order: alpha 0, bravo 1, charlie 2). Every message
// carries the sender's id and its incarnation: a random number drawn when the daemon starts,
// so receivers notice a restart and forget what they held for the old incarnation.
#pragma once

#include <cstdint>
#include <vector>

#include "draco/msgs/loops.hpp"
#include "draco/msgs/objects.hpp"
#include "draco/msgs/slam.hpp"

namespace draco::msgs {

// The kinds of fleet messages; the value is the kind byte on the link (never reorder).
enum class FleetKind : std::uint8_t {
  kHeartbeat = 1,
  kObjectMap = 2,      // object-map update (delta against a version the receivers hold)
  kKeyframePoses = 3,  // new keyframes and keyframes that moved
  kScanRequest = 4,
  kScanReply = 5,
  kLoopClosures = 6,  // accepted inter-robot loops, sent to the teammate they involve
};
inline constexpr int kNumFleetKinds = 7;  // index by the kind value; 0 unused
inline const char* FleetKindName(FleetKind kind) {
  switch (kind) {
    case FleetKind::kHeartbeat:
      return "heartbeat";
    case FleetKind::kObjectMap:
      return "object_map";
    case FleetKind::kKeyframePoses:
      return "keyframe_poses";
    case FleetKind::kScanRequest:
      return "scan_request";
    case FleetKind::kScanReply:
      return "scan_reply";
    case FleetKind::kLoopClosures:
      return "loop_closures";
  }
  return "unknown";
}

struct FleetHeader {
  int robot_id = 0;               // sender
  std::uint32_t incarnation = 0;  // sender's start-up random number
  std::uint32_t seq = 0;          // sender's running count of this kind
  double time_s = 0.0;            // sender's mission time at sending
};

// Liveness, the sender's mission clock, and what it holds of each teammate's object map.
struct Heartbeat {
  FleetHeader header;
  int num_keyframes = 0;
  struct Ack {
    int robot_id = 0;
    std::uint32_t incarnation = 0;
    std::uint32_t object_map_version = 0;  // 0: nothing held
  };
  std::vector<Ack> acks;
  // The sender's map-to-map estimates that accepted loops verified (T_sender_robot): a
  // teammate that cannot match robot_id itself places it through the sender.
  struct Transform {
    int robot_id = 0;
    Pose2 T_sender_robot;
  };
  std::vector<Transform> transforms;
};

inline bool operator==(const Heartbeat::Transform& a, const Heartbeat::Transform& b) {
  return a.robot_id == b.robot_id && a.T_sender_robot.x_m == b.T_sender_robot.x_m &&
         a.T_sender_robot.y_m == b.T_sender_robot.y_m &&
         a.T_sender_robot.yaw_rad == b.T_sender_robot.yaw_rad;
}

// Own verified map-to-map estimates to share (team.TwoStepOptimizer -> fleet.Link).
struct MapTransforms {
  double time_s = 0.0;
  std::vector<Heartbeat::Transform> transforms;
};

// A teammate's shared map-to-map estimates, as received (fleet.Link -> team.TwoStepOptimizer).
struct TeammateTransforms {
  FleetHeader header;
  std::vector<Heartbeat::Transform> transforms;
};

// Object-map update. version counts the sender's updates (1, 2, ...); base_version is the
// version the delta applies to (0: a full map, every object an upsert). Objects keep their
// ids (msgs::Object::id) across versions. Object keyframe lists are not sent: the teammate
// that owns the objects picks the keyframes when asked for scans (ScanRequest).
struct ObjectMapUpdate {
  FleetHeader header;
  std::uint32_t version = 0;
  std::uint32_t base_version = 0;
  std::vector<Object> upserts;         // new or changed objects (id, centre, sides, yaw, points)
  std::vector<std::uint32_t> removed;  // ids gone since base_version
  double map_heading_rad = kUnknownHeading;  // ObjectMap::map_heading_rad, in every update
};

// Keyframe poses in the sender's map frame: new keyframes and those that moved more than a
// threshold since they were last sent. full: the list is every keyframe (after a restart or on
// a teammate's first contact).
struct KeyframePoseEntry {
  int index = 0;
  double time_s = 0.0;
  Pose2 T_map_kf;
  int num_points = 0;
};
struct KeyframePoses {
  FleetHeader header;
  bool full = false;
  std::vector<KeyframePoseEntry> poses;  // ascending index
};

// "Send me scans of the keyframes that observed these objects of yours". Sent by the robot
// that matched (requester) to the owner of the objects (target). T_requester_target is the
// graph-matching transform (the owner may use it to skip scans it already sent).
struct ScanRequest {
  FleetHeader header;
  int target_robot = 0;
  std::uint32_t object_map_version = 0;  // target's version the ids refer to
  Pose2 T_requester_target;
  std::vector<std::uint32_t> object_ids;  // target's object ids, most useful first
  int max_scans = 20;
};

// One keyframe scan, sent to the requester. Points in the keyframe frame.
struct ScanReply {
  FleetHeader header;
  int requester_robot = 0;
  int keyframe = 0;
  double keyframe_time_s = 0.0;
  Pose2 T_map_kf;  // the sender's current estimate of the keyframe's pose
  std::vector<Point2> points_kf;
};

// Accepted inter-robot loops (after the consistency filter), sent to the teammate involved
// so it can use them without registering again.
struct LoopClosureMessage {
  FleetHeader header;
  int target_robot = 0;
  std::vector<InterRobotLoop> loops;
};

// ---------------------------------------------------------------------------------------
// LinkEndpoint's side of a tick (components/fleet link.hpp; not link traffic). The fleet.Link
// component fills FleetOutgoing from its per-kind inputs and publishes FleetIncoming per kind.

// What the robot wants sent (the link makes deltas, encodes, queues and counts).
struct FleetOutgoing {
  double time_s = 0.0;
  bool has_object_map = false;
  ObjectMap object_map;  // own, full
  bool has_poses = false;
  std::vector<KeyframePoseEntry> poses;  // all own keyframes, current poses
  std::vector<ScanRequest> requests;
  std::vector<ScanReply> replies;
  std::vector<LoopClosureMessage> loops;
  bool has_transforms = false;
  std::vector<Heartbeat::Transform> transforms;  // replaces the ones sent so far
};

// A teammate's object map as the link holds it after applying updates.
struct TeammateObjectMap {
  FleetHeader header;
  std::uint32_t version = 0;
  ObjectMap map;
};

enum class TeammateEventKind : std::uint8_t { kJoined, kRestarted, kSilent, kLeft };
struct TeammateEvent {
  int robot_id = 0;
  std::uint32_t incarnation = 0;
  TeammateEventKind kind = TeammateEventKind::kJoined;
};

// What arrived in one link tick, decoded and checked, in delivery order per kind.
struct FleetIncoming {
  double time_s = 0.0;
  std::vector<TeammateEvent> events;
  std::vector<TeammateObjectMap> object_maps;
  std::vector<KeyframePoses> poses;
  std::vector<ScanRequest> requests;
  std::vector<ScanReply> replies;
  std::vector<LoopClosureMessage> loops;
  std::vector<TeammateTransforms> transforms;
  bool empty() const {
    return events.empty() && object_maps.empty() && poses.empty() && requests.empty() &&
           replies.empty() && loops.empty() && transforms.empty();
  }
};

}  // namespace draco::msgs
