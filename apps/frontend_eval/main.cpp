// draco-frontend-eval MISSION_DIR [--out DIR]: the inter-robot front end measured against
// ground truth, as the paper's Fig. 3. Every robot's local SLAM runs in-process through the
// local-SLAM graph (config/graphs/local-slam.yaml, with a capture component added); at the
// end of the mission each robot's object map is built from its optimised keyframes; then for
// every ordered robot pair (a, b): object-graph matching (checked against the ground-truth
// transform between the two map frames), scan-request selection, and sliding-window
// registration for w in {0, 1, 3}, judged against the ground-truth relative pose at the
// keyframe times (true positive: within 1.5 m and 15 deg). Prints precision and
// true-positive count per (w, overlap threshold), writes CSVs and fig3.png (both against the
// threshold, one line per window).
//
//   draco-frontend-eval /tmp/marina --out runs/frontend-marina
//   draco-frontend-eval /tmp/marina --out runs/frontend-marina --reuse   (cached keyframes)
#include <CLI/CLI.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <numbers>

#include "app_version.hpp"
#include "data_path.hpp"
#include "draco/frontend/pipeline.hpp"
#include "draco/graph/executor.hpp"
#include "draco/graph/graph.hpp"
#include "draco/recording/recording.hpp"
#include "draco/registration/registration.hpp"
#include "draco/report/figures.hpp"
#include "log_option.hpp"
#include "run_info.hpp"

namespace {

using draco::msgs::Pose2;
namespace reg = draco::registration;
namespace fe = draco::frontend;
constexpr double kDeg = std::numbers::pi / 180.0;

struct Row {  // one registration
  int a, b, window, own_kf, team_kf, source_points;
  bool valid;
  double overlap, err_m, err_deg;
  bool tp;
  bool oracle;  // seeded by the ground-truth transform (matching failed)
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"draco-frontend-eval: inter-robot loop-closure precision (paper Fig. 3)"};
  draco::app::AddLogLevelOption(app);
  std::string mission;
  std::string out_dir;
  std::string graph_path;  // default: graphs/local-slam.yaml from the data search path
  std::vector<std::string> overrides;
  bool reuse = false;
  bool oracle = false;
  int jobs = 1;
  reg::SelectionOptions sel;
  reg::RegistrationOptions ro;
  double radius_m = -1, max_yaw_deg = -1;
  double default_threshold = ro.min_overlap;
  int default_window = ro.window;
  std::string metric = "point";
  double tp_m = 1.5, tp_deg = 15.0;
  draco::objects::ObjectMapperOptions mapper;
  draco::objects::MatcherOptions matcher;
  std::string affinity;  // empty: the default
  double line_angle_deg = 0.0, corner_min_deg = 0.0;
  double over_time_s = 0.0;
  fe::OverTimeOptions over_time;
  app.add_option("mission", mission, "recorded mission folder")->required();
  app.add_option("--out", out_dir, "output folder (default runs/frontend-<mission>)");
  app.add_option("--graph", graph_path, "local-SLAM graph YAML (default: graphs/local-slam.yaml)");
  app.add_option("--set", overrides, "local-SLAM graph override component.param=value");
  app.add_flag("--oracle-matching", oracle,
               "where matching fails, seed registration with the ground-truth transform and "
               "true object pairs (registration measured alone)");
  bool chain = true;
  app.add_flag("!--no-chain", chain,
               "no scans for a pair that does not match, even when teammates' matches chain "
               "(T_a_b = T_a_c * T_c_b, as the running team shares its transforms)");
  double chain_pair_margin_m = -1.0;
  app.add_option("--chain-pair-margin", chain_pair_margin_m,
                 "chained transforms: object rectangles grown by this margin m pair when they meet "
                 "(default 1)");
  bool possible_loops = true;
  app.add_flag("!--no-possible-loops", possible_loops,
               "skip the ground-truth seeded registration of every keyframe pair in range");
  app.add_flag("--reuse", reuse, "reuse the keyframes cached in the out folder");
  app.add_option("--jobs", jobs, "robots run in parallel");
  app.add_option("--max-requests", sel.max_requests, "scan requests per exchange");
  app.add_option("--max-candidates", sel.max_candidates_per_request,
                 "own keyframes registered per request (0: all within the radius)");
  app.add_option("--radius", radius_m, "candidate radius m (default 40, airplane 20)");
  app.add_option("--max-yaw-deg", max_yaw_deg, "candidate heading limit (180, airplane 90)");
  app.add_flag("--reference-window", ro.reference_window, "the reference's k-w..k+w-1 + k");
  app.add_option("--metric", metric, "point | line");
  app.add_option("--overlap-distance", ro.icp.overlap_distance_m, "overlap inlier distance m");
  app.add_option("--max-correction", ro.max_correction_m, "gate on the ICP correction m (0 off)");
  app.add_option("--threshold", default_threshold, "the default overlap threshold to report");
  app.add_option("--window", default_window, "the default window to report");
  app.add_option("--eps", mapper.dbscan.eps_m, "DBSCAN eps m");
  app.add_option("--min-samples", mapper.dbscan.min_points, "DBSCAN min points");
  app.add_option("--n-min", mapper.min_points, "object filter: min points");
  app.add_option("--d-min", mapper.min_length_m, "object filter: min long side m");
  app.add_flag("--rect-center", mapper.rectangle_center, "object centre = rectangle centre");
  app.add_option("--affinity", affinity, "code | paper | relative (default)");
  app.add_option("--mu", matcher.mu_per_m, "affinity mu per m");
  app.add_option("--relative-shape", matcher.relative_shape_per_m,
                 "relative affinity: shape tolerance growth per m of length");
  app.add_option("--min-affinity", matcher.min_affinity, "sparse affinity: smallest entry");
  app.add_option("--min-shape", matcher.min_shape_similarity,
                 "sparse affinity: smallest shape term");
  app.add_option("--min-inliers", matcher.min_inliers, "RANSAC min inliers");
  app.add_option("--min-assignments", matcher.min_assignments, "min assignments");
  app.add_option("--min-objects", matcher.min_objects, "min objects per map");
  app.add_option("--ransac-m", matcher.ransac_threshold_m, "RANSAC threshold m");
  app.add_option("--over-time", over_time_s,
                 "also match the maps of both robots at the same time every S seconds");
  app.add_option("--miss-weight", matcher.miss_weight,
                 "negative evidence: RANSAC score = inliers - W x objects placed on observed empty "
                 "space (0 off)");
  app.add_option("--miss-distance", matcher.miss_distance_m, "negative evidence: miss distance m");
  app.add_option("--coverage-range", over_time.coverage.range_m,
                 "negative evidence: observed range from a keyframe m");
  app.add_option("--ambiguity", matcher.max_ambiguity_ratio,
                 "no match when a distinct runner-up scores >= this fraction of the best (0 off)");
  app.add_option("--distinct-m", matcher.distinct_m, "ambiguity: distinct hypotheses m apart");
  app.add_option("--split", mapper.split_min_length_m,
                 "objects: clusters at least this long and not slender become their straight "
                 "segments (0 off)");
  app.add_option("--split-aspect", mapper.split_max_aspect, "objects: split below this aspect");
  app.add_option("--segment-min-length", mapper.segments.min_length_m, "segments: min length m");
  app.add_flag("--lines", matcher.structure_lines,
               "also match by the axes of long objects (corners of structure lines)");
  app.add_option("--line-min-length", matcher.lines.min_length_m, "lines: min object length m");
  app.add_option("--line-aspect", matcher.lines.min_aspect, "lines: min length / breadth");
  app.add_option("--line-lateral", matcher.lines.lateral_tolerance_m,
                 "lines: lateral offset tolerance m");
  app.add_option("--line-gap", matcher.lines.max_gap_m, "lines: extents may miss by this m");
  app.add_option("--line-reach", matcher.lines.max_reach_m,
                 "lines: corner at most this far beyond a segment m");
  app.add_option("--line-angle-deg", line_angle_deg, "lines: angle tolerance deg");
  app.add_option("--corner-min-deg", corner_min_deg, "lines: min corner angle deg");
  app.add_option("--line-support", matcher.min_line_support, "lines: min support");
  app.add_option("--line-ambiguity", matcher.max_line_ambiguity,
                 "lines: no match when a distinct runner-up has this fraction of the support");
  app.add_option("--line-compact", matcher.lines.max_compact_length_m,
                 "lines: compact objects up to this long m");
  int landmarks = -1;  // -1: the options' defaults
  app.add_option("--landmarks", landmarks,
                 "local-SLAM landmarks seen at least N times join the object maps and are matched "
                 "as points first (0: off)");
  app.add_option("--landmark-support", matcher.min_landmark_support,
                 "landmarks: min pairs of an answer");
  app.add_option("--landmark-ambiguity", matcher.max_landmark_ambiguity,
                 "landmarks: no answer when a distinct runner-up has this fraction of the pairs");
  app.add_option("--landmark-wide-tolerance", matcher.wide_landmark_tolerance_m,
                 "landmarks: second pass tolerance m (0: no second pass)");
  app.add_option("--landmark-wide-ambiguity", matcher.wide_max_landmark_ambiguity,
                 "landmarks: second pass ambiguity limit");
  app.add_option("--landmark-tolerance", matcher.landmark.tolerance_m,
                 "landmarks: distance agreement and inlier radius m");
  app.add_flag("--track", over_time.track,
               "--over-time: accept a transform only after it won repeatedly (MatchTracker)");
  app.add_option("--track-votes", over_time.tracker.min_votes, "tracker: wins needed");
  app.add_option("--track-dominance", over_time.tracker.dominance,
                 "tracker: votes over every other track's");
  app.set_version_flag("--version", draco::app::VersionLine("draco-frontend-eval"));
  CLI11_PARSE(app, argc, argv);
  if (landmarks >= 0) {
    mapper.landmark_min_sightings = landmarks;
    matcher.landmarks = landmarks > 0;
  }
  if (corner_min_deg > 0)
    matcher.lines.min_corner_angle_rad = corner_min_deg * std::numbers::pi / 180;
  if (line_angle_deg > 0)
    matcher.lines.angle_tolerance_rad = line_angle_deg * std::numbers::pi / 180;
  if (affinity == "paper") matcher.affinity = draco::objects::AffinityForm::kPaper;
  if (affinity == "relative") matcher.affinity = draco::objects::AffinityForm::kRelative;
  if (affinity == "code") matcher.affinity = draco::objects::AffinityForm::kCode;
  ro.icp.metric =
      metric == "line" ? draco::icp::Metric::kPointToLine : draco::icp::Metric::kPointToPoint;
  ro.min_overlap = 0.0;  // thresholds are applied below

  try {
    const auto info = draco::recording::LoadMissionInfo(mission);
    graph_path = draco::app::ResolveDataFile("graphs/local-slam.yaml", graph_path).path;
    if (out_dir.empty()) out_dir = "runs/frontend-" + info.name;
    std::filesystem::create_directories(out_dir + "/slam");
    auto run_info = draco::app::MakeRunInfo("draco-frontend-eval", argc, argv);
    run_info.AddFile("graph", graph_path);
    draco::app::WriteRunInfo(out_dir, run_info);
    const bool airplane = info.world.find("airplane") != std::string::npos ||
                          info.name.find("airplane") != std::string::npos;
    if (airplane) {
      const auto a = reg::AirplaneSelectionOptions();
      sel.candidate_radius_m = a.candidate_radius_m;
      sel.candidate_max_yaw_rad = a.candidate_max_yaw_rad;
    }
    if (radius_m > 0) sel.candidate_radius_m = radius_m;
    if (max_yaw_deg > 0) sel.candidate_max_yaw_rad = max_yaw_deg * kDeg;

    // Local SLAM per robot (or the cache), truth, object maps.
    fe::SlamRunOptions slam_options{graph_path, overrides, reuse, jobs, mapper};
    double slam_s = 0.0;
    std::vector<fe::Robot> robots = fe::RunRobots(mission, info, out_dir, slam_options, &slam_s);

    std::string objects_csv = "robot,id,x_m,y_m,world_x_m,world_y_m,length_m,breadth_m,points\n";
    std::string kf_csv =
        "robot,index,time_s,x_m,y_m,yaw_rad,world_x_m,world_y_m,truth_x_m,truth_y_m\n";
    for (const auto& r : robots) {
      for (const auto& o : r.objects.objects) {
        const auto w = reg::Apply(r.T_world_map, o.center);
        char line[256];
        std::snprintf(line, sizeof(line), "%s,%u,%.3f,%.3f,%.3f,%.3f,%.2f,%.2f,%d\n",
                      r.name.c_str(), o.id, o.center.x_m, o.center.y_m, w.x_m, w.y_m, o.length_m,
                      o.breadth_m, o.num_points);
        objects_csv += line;
      }
      for (std::size_t i = 0; i < r.kfs.size(); ++i) {
        const auto& k = r.kfs[i];
        const auto w = reg::Compose(r.T_world_map, k.T_map_kf);
        char line[256];
        std::snprintf(line, sizeof(line), "%s,%d,%.3f,%.3f,%.3f,%.4f,%.3f,%.3f,%.3f,%.3f\n",
                      r.name.c_str(), k.index, k.time_s, k.T_map_kf.x_m, k.T_map_kf.y_m,
                      k.T_map_kf.yaw_rad, w.x_m, w.y_m, r.truth_kf[i].x_m, r.truth_kf[i].y_m);
        kf_csv += line;
      }
    }
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/objects.csv", objects_csv);
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/keyframes.csv", kf_csv);

    // Pairs.
    std::vector<Row> rows;
    std::string match_csv =
        "own,teammate,own_objects,teammate_objects,shared_objects,status,inliers,confidence,"
        "err_m,err_deg,correct,requests,registrations,oracle\n";
    int pairs_eligible = 0, pairs_eligible_correct = 0, pairs_matched_correct = 0;
    std::map<std::pair<int, int>, int> shared_of;
    double reg_time_s = 0.0;
    int reg_count = 0;
    fe::PairOptions po;
    po.selection = sel;
    po.registration = ro;
    po.oracle = oracle;
    po.matcher = matcher;
    po.coverage = over_time.coverage;
    po.tp_m = tp_m;
    po.tp_deg = tp_deg;
    if (chain_pair_margin_m > 0) po.chain_pair_margin_m = chain_pair_margin_m;
    std::map<std::pair<std::size_t, std::size_t>, fe::PairResult> direct;
    for (std::size_t ia = 0; ia < robots.size(); ++ia) {
      for (std::size_t ib = 0; ib < robots.size(); ++ib) {
        if (ia != ib) direct[{ia, ib}] = fe::MatchAndRegister(robots[ia], robots[ib], po);
      }
    }
    for (std::size_t ia = 0; ia < robots.size(); ++ia) {
      for (std::size_t ib = 0; ib < robots.size(); ++ib) {
        if (ia == ib) continue;
        const fe::Robot& A = robots[ia];
        const fe::Robot& B = robots[ib];
        fe::PairResult pr = direct.at({ia, ib});
        bool chained = false;
        if (chain && !pr.matched && !pr.oracle_used) {
          // The transform a teammate c shares: T_a_b = T_a_c * T_c_b, both from matching.
          for (std::size_t ic = 0; ic < robots.size() && !chained; ++ic) {
            if (ic == ia || ic == ib) continue;
            const auto& ac = direct.at({ia, ic});
            const auto& cb = direct.at({ic, ib});
            if (!ac.matched || !cb.matched) continue;
            pr = fe::RegisterWithTransform(A, B, reg::Compose(ac.match.T_a_b, cb.match.T_a_b), po);
            chained = true;
            std::printf(
                "%s <- %s: no match; chained through %s (%.2f m, %.2f deg off the truth), "
                "%zu object pairs, %zu requests\n",
                A.name.c_str(), B.name.c_str(), robots[ic].name.c_str(), pr.err_m, pr.err_deg,
                pr.match.pairs.size(), pr.requests);
          }
        }
        const int shared = pr.shared_objects;
        shared_of[{static_cast<int>(ia), static_cast<int>(ib)}] = shared;
        if (shared >= 5) {
          ++pairs_eligible;
          pairs_eligible_correct += pr.correct;
        }
        pairs_matched_correct += pr.correct;
        reg_time_s += pr.registration_time_s;
        const int registrations = static_cast<int>(pr.registrations.size());
        reg_count += registrations;
        for (const auto& r : pr.registrations) {
          rows.push_back({static_cast<int>(ia), static_cast<int>(ib), r.window, r.own_kf, r.team_kf,
                          r.source_points, r.valid, r.overlap, r.err_m, r.err_deg, r.tp, r.oracle});
        }
        const auto& match = pr.match;
        const bool matched = pr.matched || chained, correct = pr.correct,
                   oracle_used = pr.oracle_used;
        const double err_m = pr.err_m, err_deg = pr.err_deg;
        const std::size_t num_requests = pr.requests;
        char line[256];
        std::snprintf(
            line, sizeof(line), "%s,%s,%zu,%zu,%d,%s,%d,%.3f,%.3f,%.3f,%d,%zu,%d,%d\n",
            A.name.c_str(), B.name.c_str(), A.objects.objects.size(), B.objects.objects.size(),
            shared, chained ? "chained" : draco::msgs::MatchStatusName(match.status),
            match.num_inliers, match.confidence, matched ? err_m : -1.0, matched ? err_deg : -1.0,
            correct ? 1 : 0, num_requests, registrations, oracle_used ? 1 : 0);
        match_csv += line;
      }
    }

    // Time-consistent matching.
    if (over_time_s > 0) {
      std::string ot_csv =
          "own,teammate,time_s,own_objects,teammate_objects,shared_objects,status,inliers,err_m,"
          "err_deg,correct,true_support,true_line_support\n";
      int pairs_right = 0, pairs_wrong = 0, answers = 0, answers_right = 0;
      int steps = 0, eligible = 0, eligible_right = 0, eligible_wrong = 0;
      std::printf("\ntime-consistent matching every %.0f s (own <- teammate):\n", over_time_s);
      for (std::size_t ia = 0; ia < robots.size(); ++ia) {
        for (std::size_t ib = 0; ib < robots.size(); ++ib) {
          if (ia == ib) continue;
          const auto series =
              fe::MatchOverTime(robots[ia], robots[ib], mapper, matcher, over_time_s, over_time);
          int matched = 0, right = 0, max_shared = 0;
          double first_right = -1;
          for (const auto& m : series) {
            matched += m.matched;
            right += m.correct;
            ++steps;
            if (m.shared >= 5) {
              ++eligible;
              eligible_right += m.correct;
              eligible_wrong += m.matched && !m.correct;
            }
            max_shared = std::max(max_shared, m.shared);
            if (m.correct && first_right < 0) first_right = m.time_s;
            char line[256];
            std::snprintf(line, sizeof(line), "%s,%s,%.1f,%d,%d,%d,%s,%d,%.3f,%.3f,%d,%d,%d\n",
                          robots[ia].name.c_str(), robots[ib].name.c_str(), m.time_s, m.objects_a,
                          m.objects_b, m.shared, draco::msgs::MatchStatusName(m.match.status),
                          m.match.num_inliers, m.matched ? m.err_m : -1.0,
                          m.matched ? m.err_deg : -1.0, m.correct ? 1 : 0, m.true_support,
                          m.true_line_support);
            ot_csv += line;
          }
          answers += matched;
          answers_right += right;
          pairs_right += right > 0;
          pairs_wrong += matched > right;
          std::printf(
              "  %-8s <- %-8s steps %3zu, max shared %2d, matched %3d, right %3d, wrong %3d, "
              "first right %.0f s\n",
              robots[ia].name.c_str(), robots[ib].name.c_str(), series.size(), max_shared, matched,
              right, matched - right, first_right);
        }
      }
      std::printf(
          "time-consistent: %d of %zu pairs matched right at least once, %d pairs with a "
          "wrong match; answers %d right of %d matched\n",
          pairs_right, robots.size() * (robots.size() - 1), pairs_wrong, answers_right, answers);
      std::printf(
          "time-consistent, steps sharing >= 5 true objects: %d of %d; right %d, wrong %d, none "
          "%d\n",
          eligible, steps, eligible_right, eligible_wrong,
          eligible - eligible_right - eligible_wrong);
      draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/matching_over_time.csv", ot_csv);
    }

    // Tables.
    std::string reg_csv =
        "own,teammate,window,own_kf,teammate_kf,source_points,valid,overlap,"
        "err_m,err_deg,true_positive,oracle\n";
    for (const auto& r : rows) {
      char line[256];
      std::snprintf(line, sizeof(line), "%s,%s,%d,%d,%d,%d,%d,%.4f,%.3f,%.3f,%d,%d\n",
                    robots[r.a].name.c_str(), robots[r.b].name.c_str(), r.window, r.own_kf,
                    r.team_kf, r.source_points, r.valid ? 1 : 0, r.overlap, r.err_m, r.err_deg,
                    r.tp ? 1 : 0, r.oracle ? 1 : 0);
      reg_csv += line;
    }
    std::string prec_csv = "window,threshold,detections,true_positives,precision\n";
    // Fig. 3: precision and true positives against the threshold, one line per window.
    draco::report::ChartPanel fig_prec, fig_tp;
    std::printf("\nmission %s (%s): %zu robots, local SLAM %.1f s wall\n", info.name.c_str(),
                info.world.c_str(), robots.size(), slam_s);
    for (const auto& r : robots) {
      std::printf("  %-8s %5zu keyframes, %3zu objects\n", r.name.c_str(), r.kfs.size(),
                  r.objects.objects.size());
    }
    std::printf("%s", ("\nobject-graph matching (own <- teammate):\n" + match_csv).c_str());
    std::printf(
        "matching right (<= 2 m, 10 deg): %d of %d pairs sharing >= 5 true objects (%.0f %%); "
        "%d of %zu ordered pairs overall\n",
        pairs_eligible_correct, pairs_eligible,
        pairs_eligible ? 100.0 * pairs_eligible_correct / pairs_eligible : 0.0,
        pairs_matched_correct, robots.size() * (robots.size() - 1));
    std::printf("registrations: %d, %.3f ms mean\n\n", reg_count,
                reg_count ? 1e3 * reg_time_s / reg_count : 0.0);
    std::printf("%-9s", "overlap");
    for (const int w : {0, 1, 3}) std::printf("  w=%d prec   TP  det", w);
    std::printf("\n");
    for (const int w : {0, 1, 3}) {
      const std::string label = "window " + std::to_string(w);
      fig_prec.series.push_back({label, {}, {}, {}, false, true});
      fig_tp.series.push_back({label, {}, {}, {}, false, true});
    }
    for (int ti = 0; ti <= 9; ++ti) {
      const double thr = 0.5 + 0.05 * ti;
      std::printf("%-9.2f", thr);
      for (std::size_t wi = 0; wi < 3; ++wi) {
        const int w = std::array{0, 1, 3}[wi];
        int det = 0, tp = 0;
        for (const auto& r : rows) {
          if (r.window != w || !r.valid || r.overlap < thr - 1e-9) continue;
          ++det;
          tp += r.tp;
        }
        const double prec = det ? static_cast<double>(tp) / det : 0.0;
        std::printf("  %8.3f %4d %4d", prec, tp, det);
        if (det > 0) {  // no detection: no precision point
          fig_prec.series[wi].x.push_back(thr);
          fig_prec.series[wi].y.push_back(prec);
        }
        fig_tp.series[wi].x.push_back(thr);
        fig_tp.series[wi].y.push_back(tp);
        char line[128];
        std::snprintf(line, sizeof(line), "%d,%.2f,%d,%d,%.4f\n", w, thr, det, tp, prec);
        prec_csv += line;
      }
      std::printf("\n");
    }
    // Per pair at the default setting, and the loops a perfect matcher could have found.
    int pairs_possible = 0, pairs_possible_found = 0;
    std::string possible_csv =
        "own,teammate,pairs_tested,possible,best_overlap,true_positives,detections\n";
    std::printf("\nper pair at w=%d, overlap >= %.2f (true positives / detections):\n",
                default_window, default_threshold);
    for (std::size_t ia = 0; ia < robots.size(); ++ia) {
      for (std::size_t ib = 0; ib < robots.size(); ++ib) {
        if (ia == ib) continue;
        int det = 0, tp = 0;
        for (const auto& r : rows) {
          if (r.a != static_cast<int>(ia) || r.b != static_cast<int>(ib) ||
              r.window != default_window || !r.valid || r.overlap < default_threshold - 1e-9) {
            continue;
          }
          ++det;
          tp += r.tp;
        }
        std::string possible_text;
        if (possible_loops) {
          const auto p =
              fe::CountPossibleLoops(robots[ia], robots[ib], po, default_window, default_threshold);
          char text[160];
          std::snprintf(text, sizeof(text), "; possible %d of %d keyframe pairs (best %.2f)",
                        p.possible, p.pairs_tested, p.best_overlap);
          possible_text = text;
          if (p.possible > 0) {
            ++pairs_possible;
            pairs_possible_found += tp > 0;
          }
          char line[160];
          std::snprintf(line, sizeof(line), "%s,%s,%d,%d,%.4f,%d,%d\n", robots[ia].name.c_str(),
                        robots[ib].name.c_str(), p.pairs_tested, p.possible, p.best_overlap, tp,
                        det);
          possible_csv += line;
        }
        std::printf("  %-8s <- %-8s shared objects %3d: %d / %d%s\n", robots[ia].name.c_str(),
                    robots[ib].name.c_str(),
                    shared_of[{static_cast<int>(ia), static_cast<int>(ib)}], tp, det,
                    possible_text.c_str());
      }
    }
    if (possible_loops) {
      std::printf(
          "ordered pairs with a possible loop (ground-truth seeded, w=%d, overlap >= %.2f, "
          "true positive): %d; with >= 1 true positive found: %d\n",
          default_window, default_threshold, pairs_possible, pairs_possible_found);
      draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/possible_loops.csv", possible_csv);
    }
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/matching.csv", match_csv);
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/registrations.csv", reg_csv);
    draco::graph::WriteFileAtomicallyOrThrow(out_dir + "/precision.csv", prec_csv);
    for (auto* panel : {&fig_prec, &fig_tp}) {
      panel->options.x_label = "overlap threshold";
      panel->options.x_min = 0.5;
      panel->options.x_max = 0.97;
      panel->options.width_px = 700;
      panel->options.height_px = 480;
    }
    fig_prec.options.title = info.name + ": precision vs overlap threshold";
    fig_prec.options.y_label = "precision";
    fig_prec.options.y_min = 0.0;
    fig_prec.options.y_max = 1.3;  // headroom for the legend above precision 1
    fig_tp.options.title = info.name + ": true positives vs overlap threshold";
    fig_tp.options.y_label = "true positives";
    draco::report::RenderLineChartPanels({fig_prec, fig_tp}, out_dir + "/fig3.png");
    std::printf("CSVs and fig3.png in %s\n", out_dir.c_str());
    return 0;
  } catch (const draco::graph::GraphError& e) {
    draco::log::Error(e.what());
    return 1;
  } catch (const std::exception& e) {
    draco::log::Error(std::string("draco-frontend-eval: ") + e.what());
    return 1;
  }
}
