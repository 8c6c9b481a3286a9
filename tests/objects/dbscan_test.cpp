// DBSCAN: incremental == batch, stable ids, and the object mapper following moved keyframes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "draco/objects/dbscan.hpp"
#include "draco/objects/geometry.hpp"
#include "draco/objects/object_mapper.hpp"

namespace draco::objects {
namespace {

using Partition = std::set<std::set<std::size_t>>;

Partition ToPartition(const std::vector<int>& labels, std::size_t n) {
  std::map<int, std::set<std::size_t>> by_label;
  for (std::size_t i = 0; i < n; ++i) {
    if (labels[i] != kNoise) by_label[labels[i]].insert(i);
  }
  Partition out;
  for (auto& [label, members] : by_label) out.insert(members);
  return out;
}

// Blobs and sticks of points plus uniform clutter, in a shuffled order.
std::vector<Point2> RandomWorld(std::mt19937_64* rng, int blobs, int points_per_blob, int clutter,
                                double size_m) {
  std::uniform_real_distribution<double> u(0.0, size_m);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Point2> points;
  for (int b = 0; b < blobs; ++b) {
    const double cx = u(*rng), cy = u(*rng), sx = 0.3 + 2.0 * u(*rng) / size_m,
                 sy = 0.3 + 0.5 * u(*rng) / size_m;
    for (int i = 0; i < points_per_blob; ++i)
      points.push_back({cx + sx * g(*rng), cy + sy * g(*rng)});
  }
  for (int i = 0; i < clutter; ++i) points.push_back({u(*rng), u(*rng)});
  std::shuffle(points.begin(), points.end(), *rng);
  return points;
}

TEST(Dbscan, BatchFindsTwoBlobsAndNoise) {
  std::vector<Point2> points;
  for (int i = 0; i < 30; ++i) points.push_back({0.05 * i, 0.0});
  for (int i = 0; i < 30; ++i) points.push_back({20.0 + 0.05 * i, 0.0});
  points.push_back({10.0, 10.0});
  const auto labels = DbscanBatch(points, {});
  EXPECT_EQ(labels[0], 0);
  EXPECT_EQ(labels[29], 0);
  EXPECT_EQ(labels[30], 1);
  EXPECT_EQ(labels[60], kNoise);
}

// The header's definition, pair by pair (O(n^2)): labels, ids and border rule included.
std::vector<int> BruteForceDbscan(const std::vector<Point2>& p, const DbscanOptions& o) {
  const std::size_t n = p.size();
  const double r2 = o.eps_m * o.eps_m;
  const auto d2 = [&](std::size_t i, std::size_t j) {
    const double ex = p[j].x_m - p[i].x_m, ey = p[j].y_m - p[i].y_m;
    return ex * ex + ey * ey;
  };
  std::vector<bool> core(n);
  for (std::size_t i = 0; i < n; ++i) {
    int count = 0;
    for (std::size_t j = 0; j < n; ++j) count += d2(i, j) <= r2 ? 1 : 0;
    core[i] = count >= o.min_points;
  }
  std::vector<int> labels(n, kNoise);
  int next = 0;
  for (std::size_t seed = 0; seed < n; ++seed) {
    if (!core[seed] || labels[seed] != kNoise) continue;
    std::vector<std::size_t> stack{seed};
    labels[seed] = next;
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      for (std::size_t j = 0; j < n; ++j) {
        if (core[j] && labels[j] == kNoise && d2(i, j) <= r2) {
          labels[j] = next;
          stack.push_back(j);
        }
      }
    }
    ++next;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (core[i]) continue;
    double best = r2;
    for (std::size_t j = 0; j < n; ++j) {  // nearest core point; ties: the lower index
      if (core[j] && d2(i, j) <= best && (labels[i] == kNoise || d2(i, j) < best)) {
        best = d2(i, j);
        labels[i] = labels[j];
      }
    }
  }
  return labels;
}

TEST(Dbscan, BatchEqualsTheDefinitionPairByPair) {
  int clusters = 0, borders = 0;
  for (std::uint64_t seed = 1; seed <= 30; ++seed) {
    std::mt19937_64 rng(seed);
    const int blobs = 1 + static_cast<int>(seed % 5);
    auto points = RandomWorld(&rng, blobs, 10 + static_cast<int>(seed % 4) * 15,
                              static_cast<int>(seed % 7) * 20, 10.0 + 5.0 * double(seed % 3));
    for (auto& q : points) q.x_m -= 12.0;            // cells on both sides of zero
    points.push_back(points[seed % points.size()]);  // a duplicate point
    DbscanOptions o;
    o.eps_m = seed % 2 ? 1.5 : 0.8;
    o.min_points = 4 + static_cast<int>(seed % 3) * 8;
    const auto expected = BruteForceDbscan(points, o);
    ASSERT_EQ(DbscanBatch(points, o), expected) << "seed " << seed;
    clusters += *std::max_element(expected.begin(), expected.end()) + 1;
    for (std::size_t i = 0; i < points.size(); ++i) borders += expected[i] != kNoise;
  }
  EXPECT_GT(clusters, 30);  // the worlds do hold clusters
  EXPECT_GT(borders, 1000);
}

TEST(Dbscan, BatchCountsNeighboursAtExactlyEps) {
  // A lattice of spacing eps: each interior point has its 4 lattice neighbours at exactly eps
  // (distance <= eps counts) and the diagonal ones beyond.
  std::vector<Point2> points;
  for (int i = -5; i < 5; ++i) {
    for (int j = -3; j < 4; ++j) points.push_back({1.0 * i, 1.0 * j});
  }
  DbscanOptions o;
  o.eps_m = 1.0;
  o.min_points = 5;  // itself and 4 at exactly eps: interior points are core
  const auto labels = DbscanBatch(points, o);
  EXPECT_EQ(labels, BruteForceDbscan(points, o));
  EXPECT_EQ(labels[static_cast<std::size_t>(3 * 7 + 3)], 0);  // interior
  EXPECT_EQ(labels[3], 0);       // (-5, 0), an edge: a border point of the one cluster
  EXPECT_EQ(labels[0], kNoise);  // (-5, -3), a corner: its neighbours are edges, not core
  o.min_points = 6;              // no point has 5 neighbours within eps: all noise
  const auto none = DbscanBatch(points, o);
  EXPECT_TRUE(std::all_of(none.begin(), none.end(), [](int l) { return l == kNoise; }));
}

TEST(Dbscan, IncrementalEqualsBatchOnRandomSequences) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    std::mt19937_64 rng(seed);
    const DbscanOptions options{.eps_m = 1.5, .min_points = 5 + int(seed % 4) * 5};
    const auto world = RandomWorld(&rng, 12, 60, 400, 60.0);
    IncrementalDbscan dbscan(options);
    std::uniform_int_distribution<int> chunk(1, 120);
    std::vector<Point2> so_far;
    std::vector<int> previous;
    for (std::size_t next = 0; next < world.size();) {
      const std::size_t end = std::min(world.size(), next + chunk(rng));
      std::vector<Point2> batch(world.begin() + next, world.begin() + end);
      so_far.insert(so_far.end(), batch.begin(), batch.end());
      dbscan.Add(batch);
      next = end;
      const std::vector<int> labels = dbscan.Labels();
      ASSERT_EQ(ToPartition(labels, so_far.size()),
                ToPartition(DbscanBatch(so_far, options), so_far.size()))
          << "seed " << seed << " after " << so_far.size() << " points";
      // Id stability: a core point keeps the oldest id among the clusters merged into its
      // cluster; ids never change otherwise.
      std::map<int, int> oldest;  // new id -> min previous id of its old core points
      for (std::size_t i = 0; i < previous.size(); ++i) {
        if (previous[i] == kNoise || !dbscan.IsCore(i)) continue;
        auto [it, inserted] = oldest.emplace(labels[i], previous[i]);
        if (!inserted) it->second = std::min(it->second, previous[i]);
      }
      for (std::size_t i = 0; i < previous.size(); ++i) {
        if (previous[i] != kNoise && dbscan.IsCore(i)) {
          ASSERT_EQ(labels[i], oldest[labels[i]]) << "seed " << seed;
        }
      }
      previous = labels;
    }
  }
}

// Rebuild computes in batch the state Add leaves: the same labels (ids included) and core
// flags, and every later Add continues the same way (counts below min_points exact, roots and
// nearest core points as Add keeps them).
TEST(Dbscan, RebuildLeavesTheStateOfAdd) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    std::mt19937_64 rng(seed);
    const DbscanOptions options{.eps_m = 1.5, .min_points = 5 + int(seed % 4) * 5};
    const auto world = RandomWorld(&rng, 12, 60, 400, 60.0);
    const std::size_t split = std::uniform_int_distribution<std::size_t>(0, world.size())(rng);
    const std::vector<Point2> first(world.begin(), world.begin() + std::ptrdiff_t(split));
    IncrementalDbscan added(options), rebuilt(options);
    added.Add(first);
    rebuilt.Add({{500.0, 500.0}, {900.0, 900.0}});  // points to forget
    rebuilt.Rebuild(first);
    ASSERT_EQ(rebuilt.size(), first.size());
    ASSERT_EQ(rebuilt.Labels(), added.Labels()) << "seed " << seed;
    for (std::size_t i = 0; i < first.size(); ++i) ASSERT_EQ(rebuilt.IsCore(i), added.IsCore(i));
    std::uniform_int_distribution<int> chunk(1, 120);
    for (std::size_t next = split; next < world.size();) {
      const std::size_t end = std::min(world.size(), next + chunk(rng));
      const std::vector<Point2> batch(world.begin() + std::ptrdiff_t(next),
                                      world.begin() + std::ptrdiff_t(end));
      added.Add(batch);
      rebuilt.Add(batch);
      next = end;
      ASSERT_EQ(rebuilt.Labels(), added.Labels()) << "seed " << seed << " at " << end;
    }
  }
}

TEST(Dbscan, MergeKeepsOldestId) {
  const DbscanOptions options{.eps_m = 1.0, .min_points = 3};
  IncrementalDbscan dbscan(options);
  std::vector<Point2> left, right, bridge;
  for (int i = 0; i < 10; ++i) left.push_back({0.5 * i, 0.0});         // x in [0, 4.5]
  for (int i = 0; i < 10; ++i) right.push_back({8.0 + 0.5 * i, 0.0});  // x in [8, 12.5]
  for (int i = 0; i < 6; ++i) bridge.push_back({5.0 + 0.5 * i, 0.0});  // fills the gap
  dbscan.Add(right);
  dbscan.Add(left);
  EXPECT_EQ(dbscan.Label(0), 0);   // right: first cluster
  EXPECT_EQ(dbscan.Label(10), 1);  // left
  dbscan.Add(bridge);
  for (std::size_t i = 0; i < dbscan.size(); ++i) EXPECT_EQ(dbscan.Label(i), 0);
}

TEST(ObjectMapper, ObjectsFiltersAndKeyframes) {
  ObjectMapper mapper;  // eps 1.5, min points 20, d_min 3 m
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::vector<Point2> wall, post;
  for (int i = 0; i < 80; ++i) wall.push_back({10.0 + 8.0 * (u(rng) + 0.5), 0.4 * u(rng)});
  for (int i = 0; i < 40; ++i) post.push_back({0.8 * u(rng), 20.0 + 0.8 * u(rng)});  // < 3 m
  mapper.AddKeyframe(0, {}, wall);
  mapper.AddKeyframe(1, {0.0, 0.0, 0.0}, post);
  // The same wall seen from a second keyframe, 5 m ahead and turned by 90 deg.
  std::vector<Point2> wall_kf2;
  const Pose2 T{5.0, 0.0, M_PI / 2};
  for (const auto& p : wall) {
    const double x = p.x_m - T.x_m, y = p.y_m - T.y_m;
    wall_kf2.push_back({y, -x});  // inverse of a 90 deg rotation
  }
  mapper.AddKeyframe(2, T, wall_kf2);
  const auto map = mapper.Objects(3, 1.0);
  ASSERT_EQ(map.objects.size(), 1u);
  const auto& wall_object = map.objects[0];
  EXPECT_EQ(wall_object.num_points, 160);
  EXPECT_EQ(wall_object.keyframes, (std::vector<int>{0, 2}));
  EXPECT_NEAR(wall_object.center.x_m, 14.0, 0.5);
  EXPECT_NEAR(wall_object.length_m, 8.0, 0.3);
  EXPECT_LT(wall_object.breadth_m, 0.41);
  EXPECT_EQ(map.robot_id, 3);
}

TEST(ObjectMapper, FollowsMovedKeyframesLikeAFreshRun) {
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g(0.0, 0.3);
  const ObjectMapperOptions options;
  ObjectMapper mapper(options);
  // A row of piles seen by 30 keyframes along a line; odometry drifts in yaw.
  std::vector<Pose2> truth, drifted;
  std::vector<std::vector<Point2>> scans;
  for (int k = 0; k < 30; ++k) {
    truth.push_back({2.0 * k, 0.0, 0.0});
    drifted.push_back({2.0 * k, 0.02 * k * k, 0.004 * k});
    std::vector<Point2> scan;  // points of piles at x = 0, 10, 20, ..., y = 8, in kf frame
    for (int pile = 0; pile < 7; ++pile) {
      const double px = 12.0 * pile - truth.back().x_m;
      if (std::abs(px) > 15.0) continue;
      for (int i = 0; i < 8; ++i) scan.push_back({px + 3.0 * g(rng), 8.0 + g(rng)});
    }
    scans.push_back(scan);
    mapper.AddKeyframe(k, drifted.back(), scan);
  }
  const auto before = mapper.Objects();
  std::vector<KeyframePose> corrected;
  for (int k = 0; k < 30; ++k) corrected.push_back({k, truth[k]});
  EXPECT_TRUE(mapper.UpdatePoses(corrected));
  EXPECT_FALSE(mapper.UpdatePoses(corrected));  // nothing moved
  EXPECT_EQ(mapper.num_reclusters(), 1);
  // Same partition as clustering the corrected map from scratch.
  std::vector<Point2> placed;
  for (int k = 0; k < 30; ++k) {
    for (const auto& p : scans[k]) placed.push_back(Transform(truth[k], p));
  }
  EXPECT_EQ(ToPartition(mapper.clusters().Labels(), placed.size()),
            ToPartition(DbscanBatch(placed, options.dbscan), placed.size()));
  const auto after = mapper.Objects();
  ASSERT_GE(after.objects.size(), 5u);
  for (const auto& object : after.objects) EXPECT_NEAR(object.center.y_m, 8.0, 0.5);
  // Ids carried over: every object of the corrected map whose points were an object before
  // keeps that id.
  std::set<std::uint32_t> ids_before;
  for (const auto& o : before.objects) ids_before.insert(o.id);
  int kept = 0;
  for (const auto& o : after.objects) kept += ids_before.count(o.id) ? 1 : 0;
  EXPECT_GE(kept, static_cast<int>(after.objects.size()) - 1);
}

// SetPoses + Recluster: until Recluster the clusters keep the points where they were placed;
// a keyframe that creeps (each step under the threshold, together over it) leaves one pending.
TEST(ObjectMapper, SetPosesDefersTheReclusteringUntilAsked) {
  ObjectMapperOptions options;
  options.dbscan.min_points = 5;
  options.min_points = 5;
  ObjectMapper mapper(options);
  std::vector<Point2> pile;  // 12 points around (10, 0) in the keyframe frame
  for (int i = 0; i < 12; ++i) pile.push_back({10.0 + 0.1 * i, 0.03 * (i % 4)});
  mapper.AddKeyframe(0, {0.0, 0.0, 0.0}, pile);
  mapper.AddKeyframe(1, {0.0, 20.0, 0.0}, pile);
  ASSERT_EQ(mapper.Objects().objects.size(), 2u);
  // Keyframe 1 moved onto keyframe 0: one object once re-clustered, two until then.
  EXPECT_TRUE(mapper.SetPoses({{1, {0.0, 0.0, 0.0}}}));
  EXPECT_TRUE(mapper.recluster_pending());
  EXPECT_EQ(mapper.Objects().objects.size(), 2u);
  EXPECT_EQ(mapper.num_reclusters(), 0);
  // A new keyframe joins at its pose before the re-clustering.
  mapper.AddKeyframe(2, {0.0, 40.0, 0.0}, pile);
  EXPECT_EQ(mapper.Objects().objects.size(), 3u);
  EXPECT_TRUE(mapper.Recluster());
  EXPECT_FALSE(mapper.recluster_pending());
  EXPECT_FALSE(mapper.Recluster());  // nothing pending
  EXPECT_EQ(mapper.num_reclusters(), 1);
  const auto map = mapper.Objects();
  ASSERT_EQ(map.objects.size(), 2u);
  EXPECT_EQ(map.objects[0].num_points, 24);
  EXPECT_EQ(map.objects[0].keyframes, (std::vector<int>{0, 1}));
  EXPECT_NEAR(map.objects[0].center.y_m, 0.045, 1e-9);
  EXPECT_NEAR(map.objects[1].center.y_m, 40.045, 1e-9);
  // Creep: 0.03 m, then 0.03 m more (0.06 m from where its points are, threshold 0.05 m).
  EXPECT_FALSE(mapper.SetPoses({{2, {0.0, 40.03, 0.0}}}));
  EXPECT_TRUE(mapper.SetPoses({{2, {0.0, 40.06, 0.0}}}));
  EXPECT_TRUE(mapper.Recluster());
  EXPECT_NEAR(mapper.Objects().objects[1].center.y_m, 40.105, 1e-9);
}

// Objects() describes again only the clusters whose members changed: asked after every
// keyframe (and across a re-clustering), it gives exactly what a mapper asked once gives.
TEST(ObjectMapper, ObjectsAskedEveryStepEqualObjectsAskedOnce) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g(0.0, 0.3);
  std::vector<Pose2> poses;
  std::vector<std::vector<Point2>> scans;
  for (int k = 0; k < 40; ++k) {
    poses.push_back({2.0 * k, 0.01 * k * k, 0.003 * k});
    std::vector<Point2> scan;
    for (int pile = 0; pile < 9; ++pile) {
      const double px = 10.0 * pile - 2.0 * k;
      if (std::abs(px) > 14.0) continue;
      for (int i = 0; i < 9; ++i) scan.push_back({px + 2.0 * g(rng), 8.0 + g(rng)});
    }
    for (int i = 0; i < 3; ++i) scan.push_back({30.0 * g(rng), 20.0 * g(rng)});  // clutter
    scans.push_back(scan);
  }
  auto same = [](const msgs::ObjectMap& a, const msgs::ObjectMap& b) {
    if (a.objects.size() != b.objects.size()) return false;
    for (std::size_t i = 0; i < a.objects.size(); ++i) {
      const auto &x = a.objects[i], &y = b.objects[i];
      if (x.id != y.id || x.num_points != y.num_points || x.center.x_m != y.center.x_m ||
          x.center.y_m != y.center.y_m || x.length_m != y.length_m || x.breadth_m != y.breadth_m ||
          x.yaw_rad != y.yaw_rad || x.keyframes != y.keyframes) {
        return false;
      }
    }
    return true;
  };
  std::vector<KeyframePose> straight;  // a loop closure at keyframe 25 straightens 0-19
  for (int j = 0; j < 20; ++j) straight.push_back({j, {2.0 * j, 0.0, 0.0}});
  ObjectMapper every;
  int compared = 0;
  for (int k = 0; k < 40; ++k) {
    every.AddKeyframe(k, poses[k], scans[k]);
    if (k == 25) {
      EXPECT_TRUE(every.UpdatePoses(straight));
    }
    const auto step = every.Objects();
    ObjectMapper once;  // the same calls, Objects() only now
    for (int j = 0; j <= k; ++j) {
      once.AddKeyframe(j, poses[j], scans[j]);
      if (j == 25) once.UpdatePoses(straight);
    }
    const auto fresh = once.Objects();
    ASSERT_TRUE(same(step, fresh)) << "keyframe " << k;
    compared += static_cast<int>(fresh.objects.size());
  }
  EXPECT_GT(compared, 100);
}

}  // namespace
}  // namespace draco::objects
