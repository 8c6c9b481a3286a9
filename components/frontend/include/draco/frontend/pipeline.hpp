// The inter-robot front end of the evaluation apps (draco-frontend-eval, draco-team-eval):
// local SLAM of every robot in-process, object maps from the final keyframes, and for an
// ordered robot pair object-graph matching, scan selection and window registration, each
// judged against ground truth.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "draco/eval/trajectory.hpp"
#include "draco/msgs/loops.hpp"
#include "draco/msgs/objects.hpp"
#include "draco/objects/graph_matcher.hpp"
#include "draco/objects/object_mapper.hpp"
#include "draco/recording/recording.hpp"
#include "draco/registration/registration.hpp"

namespace draco::frontend {

using msgs::Pose2;

// A point landmark of the robot's local SLAM (OUT/slam/<robot>.landmarks.csv).
using Landmark = msgs::LandmarkEstimate;

// Reads a landmarks.csv written by slam.LocalSlam; a missing file gives no landmarks, a
// malformed one throws std::runtime_error naming the file and line.
std::vector<Landmark> LoadLandmarks(const std::string& path);

struct Robot {
  std::string name;
  int id = 0;
  std::vector<registration::KeyframeScan> kfs;  // sorted by index
  std::vector<Pose2> truth_kf;                  // world pose at each keyframe time
  std::vector<char> has_truth;
  Pose2 T_world_map;  // Umeyama alignment of the keyframes to the truth
  msgs::ObjectMap objects;
  std::vector<Landmark> landmarks;
  double slam_wall_s = 0.0;
};

// Keyframe cache (binary, this program's own format).
void SaveKeyframes(const std::string& path, const std::vector<registration::KeyframeScan>& kfs);
bool LoadKeyframes(const std::string& path, std::vector<registration::KeyframeScan>* kfs);

// Ground truth at time t (linear in position, shortest arc in yaw); false outside its span or
// across a gap over 0.5 s.
bool TruthAt(const eval::Trajectory& truth, double t, Pose2* pose);

struct SlamRunOptions {
  std::string graph_path;               // local-SLAM graph YAML
  std::vector<std::string> overrides;   // component.param=value
  bool reuse = false;                   // load OUT/slam/<robot>.keyframes.bin when present
  int jobs = 1;                         // robots in parallel (1: see docs/front-end.md)
  objects::ObjectMapperOptions mapper;  // object map from the final keyframes
};

// Object map from the keyframes with time_s <= until_s (final optimised poses); with
// options.landmark_min_sightings > 0 the landmarks seen at least that often by then join it
// (ids 0x40000000 + landmark id, flagged `landmark`, most-seen first).
msgs::ObjectMap BuildObjectMap(const Robot& r, const objects::ObjectMapperOptions& options,
                               double until_s = 1e300);
// Appends r's landmarks with at least min_sightings sightings among keyframes <= last_keyframe
// (nothing when min_sightings <= 0).
void AppendLandmarks(const Robot& r, int last_keyframe, int min_sightings, msgs::ObjectMap* map);

// Local SLAM of every robot of the mission (graph outputs in out_dir/slam: trajectory,
// dead reckoning, pose_graph.g2o, ... per robot, and the graph it ran, every parameter
// resolved, as <robot>.graph.yaml), then truth at the keyframes, the map-to-world alignment and
// the object map from the final keyframes. With options.reuse a robot whose keyframe cache is
// there is not run again (its files are those of the run that made the cache). Returns the
// robots in mission order; *wall_s is the local-SLAM wall time.
std::vector<Robot> RunRobots(const std::string& mission, const recording::MissionInfo& info,
                             const std::string& out_dir, const SlamRunOptions& options,
                             double* wall_s = nullptr);

struct PairOptions {
  registration::SelectionOptions selection;
  registration::RegistrationOptions registration;  // min_overlap is applied by the caller
  std::vector<int> windows{0, 1, 3};
  objects::MatcherOptions matcher;
  objects::CoverageOptions coverage;  // used when matcher.miss_weight > 0
  // Where matching is not right, seed registration with the ground-truth transform and the
  // true object pairs.
  bool oracle = false;
  double tp_m = 1.5;
  double tp_deg = 15.0;
  // RegisterWithTransform: objects of the two maps paired when their rectangles, grown by
  // this margin, meet under the given transform.
  double chain_pair_margin_m = 1.0;
};

struct Registration {
  int window = 0;
  int own_kf = 0;
  int team_kf = 0;
  int source_points = 0;
  bool valid = false;  // accepted by RegisterScan (ICP valid, >= min points)
  double overlap = 0.0;
  double err_m = -1.0;  // against ground truth; -1 without truth
  double err_deg = -1.0;
  bool tp = false;  // within tp_m and tp_deg
  bool oracle = false;
  msgs::InterRobotLoop loop;
};

struct PairResult {
  int shared_objects = 0;   // own objects with a teammate object within 2 m in the world
  Pose2 T_true;             // ground-truth T_a_b between the two map frames
  msgs::ObjectMatch match;  // as used (the oracle's when oracle_used)
  bool matched = false;     // matching itself answered kMatched
  bool correct = false;     // ... within 2 m and 10 deg of T_true
  double err_m = 0.0, err_deg = 0.0;
  bool oracle_used = false;
  std::size_t requests = 0;
  std::vector<Registration> registrations;
  double registration_time_s = 0.0;
};

// Matching, selection and registration of teammate B's scans against own robot A.
PairResult MatchAndRegister(const Robot& A, const Robot& B, const PairOptions& options);

// The loops a perfect matcher could have found: every teammate keyframe (>= the selection's
// min_points) against every own keyframe within the selection's candidate radius of it in the
// world, registered (window `window`) from the ground-truth relative pose. A pair counts when
// the registration is accepted at overlap >= min_overlap and lands within tp_m / tp_deg of
// the truth. This is what "the robots' paths overlap" means for loop closure: without such a
// pair no front end can close a true loop between them at that threshold.
struct PossibleLoops {
  int pairs_tested = 0;       // keyframe pairs within the radius
  int possible = 0;           // accepted, overlap >= min_overlap, true positive
  double best_overlap = 0.0;  // over the true-positive registrations at any overlap
};
PossibleLoops CountPossibleLoops(const Robot& A, const Robot& B, const PairOptions& options,
                                 int window, double min_overlap);

// Selection and registration of B's scans against A from a map-to-map transform that did not
// come from matching A's and B's maps, e.g. chained through a teammate that matched both
// (T_a_b = T_a_c * T_c_b), as the running team shares its transforms. The object pairs for
// the selection are those under the transform (objects::PairsUnderTransform, chain_pair_margin_m);
// `matched` stays false, `correct` false, err_m / err_deg judge T_a_b.
PairResult RegisterWithTransform(const Robot& A, const Robot& B, const Pose2& T_a_b,
                                 const PairOptions& options);

// The second half of MatchAndRegister: scan selection from result->match and registration.
void SelectAndRegister(const Robot& A, const Robot& B, const PairOptions& options,
                       PairResult* result);

// True shared objects: own objects with a teammate object within radius_m in the world.
int SharedObjects(const Robot& A, const msgs::ObjectMap& a, const Robot& B,
                  const msgs::ObjectMap& b, double radius_m = 2.0);

// Time-consistent matching: both robots' object maps built from the keyframes up to time t
// (final optimised poses), matched every step_s of the shared mission clock, as a running
// system that matches at every exchange would. Each answer is judged against the truth.
struct TimedMatch {
  double time_s = 0.0;
  int objects_a = 0, objects_b = 0, shared = 0;
  msgs::ObjectMatch match;
  bool matched = false, correct = false;
  double err_m = 0.0, err_deg = 0.0;
  // Support of the true transform under the structure-line scoring (matcher.lines): what the
  // maps hold for a matcher to find (lines + compact objects, and lines alone).
  int true_support = 0, true_line_support = 0;
};
// Coverage of a robot's keyframes (map frame) with time_s <= until_s (negative evidence).
objects::Coverage KeyframeCoverage(const Robot& r, const objects::CoverageOptions& options,
                                   double until_s = 1e300);

struct OverTimeOptions {
  objects::CoverageOptions coverage;  // used when the matcher's miss_weight > 0
  bool track = false;                 // pass the answers through an objects::MatchTracker
  objects::TrackerOptions tracker;
};
std::vector<TimedMatch> MatchOverTime(const Robot& A, const Robot& B,
                                      const objects::ObjectMapperOptions& mapper,
                                      const objects::MatcherOptions& matcher, double step_s,
                                      const OverTimeOptions& over_time = {});

}  // namespace draco::frontend
