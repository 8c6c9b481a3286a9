// Compact encoding of the fleet messages (msgs/fleet.hpp): what crosses the acoustic link.
// Bit-packed, fixed-point (quantisation steps in CodecOptions), varints for counts and index
// deltas, and deflate where it pays (scan points). Every field has a bound; Decode rejects a
// payload that breaks one (or is truncated, or has bytes left over) and says why: a teammate's
// garbage is counted and never trusted. The byte layout is in docs/fleet.md.
//
// Lossy: Decode(Encode(m)) equals m up to the quantisation steps (tests check the bounds).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "draco/msgs/fleet.hpp"

namespace draco::fleet {

struct CodecOptions {
  double position_step_m = 0.02;  // object centres, keyframe positions, loop translations
  double size_step_m = 0.05;      // object sides
  double yaw_step_rad = 0.001;    // keyframe and loop headings (object yaw: 8 bits of pi)
  double point_step_m = 0.05;     // scan points
  double time_step_s = 0.01;
  bool compress_points = true;  // deflate the scan points when it is smaller
};

// Bounds a decoded message must respect (and an encoder refuses to exceed).
struct Bounds {
  int max_robot_id = 63;
  int max_objects = 2048;     // per object-map update
  int max_keyframes = 20000;  // keyframe index and poses per message
  int max_points = 4096;      // per scan reply
  int max_object_ids = 256;   // per scan request
  int max_loops = 256;        // per loop message
  int max_acks = 63;
  double max_abs_coordinate_m = 20000.0;
  double max_object_side_m = 500.0;
  double max_time_s = 1e6;
};

struct DecodeResult {
  bool ok = false;
  std::string error;  // e.g. "object_map: 5000 upserts exceed the bound 2048"
  explicit operator bool() const { return ok; }
};

// Payload bytes (no frame header) of each message. Encode throws std::invalid_argument when a
// message breaks a bound.
std::vector<std::uint8_t> Encode(const msgs::Heartbeat& m, const CodecOptions& o = {});
std::vector<std::uint8_t> Encode(const msgs::ObjectMapUpdate& m, const CodecOptions& o = {});
std::vector<std::uint8_t> Encode(const msgs::KeyframePoses& m, const CodecOptions& o = {});
std::vector<std::uint8_t> Encode(const msgs::ScanRequest& m, const CodecOptions& o = {});
std::vector<std::uint8_t> Encode(const msgs::ScanReply& m, const CodecOptions& o = {});
std::vector<std::uint8_t> Encode(const msgs::LoopClosureMessage& m, const CodecOptions& o = {});

DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::Heartbeat* m,
                    const CodecOptions& o = {}, const Bounds& b = {});
DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::ObjectMapUpdate* m,
                    const CodecOptions& o = {}, const Bounds& b = {});
DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::KeyframePoses* m,
                    const CodecOptions& o = {}, const Bounds& b = {});
DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::ScanRequest* m,
                    const CodecOptions& o = {}, const Bounds& b = {});
DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::ScanReply* m,
                    const CodecOptions& o = {}, const Bounds& b = {});
DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::LoopClosureMessage* m,
                    const CodecOptions& o = {}, const Bounds& b = {});

// ---------------------------------------------------------------------------------------
// Sender-side state that keeps updates small.

// Object-map deltas: remembers the maps it sent by version (a bounded history) and builds the
// update from `base_version` (0 or unknown: full) to the current map. An object is an upsert
// when it is new or its quantised centre, sides, yaw or point count changed by more than the
// thresholds.
struct ObjectDeltaOptions {
  double min_center_change_m = 0.1;
  double min_side_change_m = 0.2;
  double min_yaw_change_rad = 0.05;
  double min_points_change_ratio = 0.2;
  int history = 16;  // versions remembered
};
class ObjectMapDeltaEncoder {
 public:
  explicit ObjectMapDeltaEncoder(const ObjectDeltaOptions& options = {});
  // The update from base_version to `current` (full when base_version is 0 or forgotten);
  // `current` becomes version+1 when the update is not empty (or is full). Returns false (and
  // leaves *update alone) when nothing changed beyond the thresholds against base_version.
  bool MakeUpdate(const msgs::ObjectMap& current, std::uint32_t base_version,
                  msgs::ObjectMapUpdate* update);
  std::uint32_t version() const { return version_; }

 private:
  ObjectDeltaOptions options_;
  std::uint32_t version_ = 0;
  std::vector<std::pair<std::uint32_t, msgs::ObjectMap>> history_;  // (version, map sent)
};

// Receiver side: applies updates to the teammate's map it holds. Returns false (map unchanged)
// when the update's base_version is not the held version and the update is not full.
bool ApplyObjectMapUpdate(const msgs::ObjectMapUpdate& update, msgs::ObjectMap* held,
                          std::uint32_t* held_version);

// Keyframe poses: new keyframes and those that moved more than the thresholds since sent.
struct PoseDeltaOptions {
  double min_translation_m = 0.1;
  double min_rotation_rad = 0.01;
};
class KeyframePoseDeltaEncoder {
 public:
  explicit KeyframePoseDeltaEncoder(const PoseDeltaOptions& options = {});
  // Entries to send now (full = everything, e.g. after a teammate restarted); false when
  // there is nothing to send.
  bool MakeUpdate(const std::vector<msgs::KeyframePoseEntry>& current, bool full,
                  msgs::KeyframePoses* update);

 private:
  PoseDeltaOptions options_;
  std::vector<msgs::KeyframePoseEntry> sent_;  // by index
};

}  // namespace draco::fleet
