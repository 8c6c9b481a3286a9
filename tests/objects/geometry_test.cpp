// Minimum-area rectangle, convex hull, rigid fit and the assignment solver.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include "draco/objects/assignment.hpp"
#include "draco/objects/geometry.hpp"

namespace draco::objects {
namespace {

std::vector<Point2> FilledRectangle(double length, double breadth, double yaw, double cx, double cy,
                                    int n, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::vector<Point2> points;
  const double c = std::cos(yaw), s = std::sin(yaw);
  // The four corners, so the hull is the rectangle, and points inside.
  for (double a : {-0.5, 0.5}) {
    for (double b : {-0.5, 0.5}) {
      points.push_back(
          {cx + c * a * length - s * b * breadth, cy + s * a * length + c * b * breadth});
    }
  }
  for (int i = 0; i < n; ++i) {
    const double a = u(*rng) * length, b = u(*rng) * breadth;
    points.push_back({cx + c * a - s * b, cy + s * a + c * b});
  }
  return points;
}

// O(h^2) reference: every hull edge direction, extents by projection of all hull points.
double BruteForceArea(const std::vector<Point2>& points) {
  const auto hull = ConvexHull(points);
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t e = 0; e < hull.size(); ++e) {
    const auto& p = hull[e];
    const auto& q = hull[(e + 1) % hull.size()];
    const double len = std::hypot(q.x_m - p.x_m, q.y_m - p.y_m);
    const double ux = (q.x_m - p.x_m) / len, uy = (q.y_m - p.y_m) / len;
    double a0 = 1e300, a1 = -1e300, b0 = 1e300, b1 = -1e300;
    for (const auto& r : hull) {
      const double a = r.x_m * ux + r.y_m * uy, b = -r.x_m * uy + r.y_m * ux;
      a0 = std::min(a0, a), a1 = std::max(a1, a), b0 = std::min(b0, b), b1 = std::max(b1, b);
    }
    best = std::min(best, (a1 - a0) * (b1 - b0));
  }
  return best;
}

TEST(Geometry, ConvexHullOfSquareWithInteriorAndCollinearPoints) {
  const std::vector<Point2> points{{0, 0}, {1, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}, {0, 1}, {1, 1}};
  const auto hull = ConvexHull(points);
  ASSERT_EQ(hull.size(), 4u);
  double area = 0.0;  // counter-clockwise: positive shoelace area
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const auto& a = hull[i];
    const auto& b = hull[(i + 1) % hull.size()];
    area += a.x_m * b.y_m - b.x_m * a.y_m;
  }
  EXPECT_DOUBLE_EQ(area / 2, 4.0);
}

TEST(Geometry, RotatedRectangleDimensionsAreRotationInvariant) {
  std::mt19937_64 rng(7);
  for (int k = 0; k < 36; ++k) {
    const double yaw = k * M_PI / 36.0 + 0.013;
    const auto points = FilledRectangle(8.0, 3.0, yaw, 12.0, -4.0, 200, &rng);
    const Rectangle r = MinAreaRectangle(points);
    EXPECT_NEAR(r.length_m, 8.0, 1e-9) << yaw;
    EXPECT_NEAR(r.breadth_m, 3.0, 1e-9) << yaw;
    EXPECT_NEAR(r.center.x_m, 12.0, 1e-9);
    EXPECT_NEAR(r.center.y_m, -4.0, 1e-9);
    const double dyaw = std::remainder(r.yaw_rad - yaw, M_PI);
    EXPECT_NEAR(dyaw, 0.0, 1e-9) << yaw;
    EXPECT_GE(r.yaw_rad, 0.0);
    EXPECT_LT(r.yaw_rad, M_PI);
  }
}

TEST(Geometry, RandomCloudsMatchBruteForceAndRotation) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<Point2> points;
    const int n = 3 + trial % 60;
    for (int i = 0; i < n; ++i) points.push_back({3.0 * g(rng), 1.0 * g(rng)});
    const Rectangle r = MinAreaRectangle(points);
    EXPECT_NEAR(r.length_m * r.breadth_m, BruteForceArea(points), 1e-9);
    for (const auto& p : points) {  // encloses every point
      const double c = std::cos(r.yaw_rad), s = std::sin(r.yaw_rad);
      const double dx = p.x_m - r.center.x_m, dy = p.y_m - r.center.y_m;
      EXPECT_LE(std::abs(c * dx + s * dy), r.length_m / 2 + 1e-9);
      EXPECT_LE(std::abs(-s * dx + c * dy), r.breadth_m / 2 + 1e-9);
    }
    const Pose2 T{5.0, -2.0, 0.7 * trial};
    std::vector<Point2> moved;
    for (const auto& p : points) moved.push_back(Transform(T, p));
    const Rectangle rm = MinAreaRectangle(moved);
    EXPECT_NEAR(rm.length_m, r.length_m, 1e-9);
    EXPECT_NEAR(rm.breadth_m, r.breadth_m, 1e-9);
  }
}

TEST(Geometry, DegenerateInputs) {
  EXPECT_EQ(MinAreaRectangle({}).length_m, 0.0);
  const Rectangle one = MinAreaRectangle({{1, 2}, {1, 2}});
  EXPECT_EQ(one.length_m, 0.0);
  EXPECT_EQ(one.center.x_m, 1.0);
  const Rectangle line = MinAreaRectangle({{0, 0}, {1, 1}, {2, 2}, {3, 3}});
  EXPECT_NEAR(line.length_m, 3.0 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(line.breadth_m, 0.0, 1e-12);
  EXPECT_NEAR(line.yaw_rad, M_PI / 4, 1e-12);
}

TEST(Geometry, FitRigidRecoversTransform) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-50, 50);
  const Pose2 T{3.0, -7.0, 2.5};
  std::vector<Point2> a, b;
  for (int i = 0; i < 10; ++i) {
    b.push_back({u(rng), u(rng)});
    a.push_back(Transform(T, b.back()));
  }
  const Pose2 fit = FitRigid(a, b);
  EXPECT_NEAR(fit.x_m, T.x_m, 1e-9);
  EXPECT_NEAR(fit.y_m, T.y_m, 1e-9);
  EXPECT_NEAR(NormalizeAngle(fit.yaw_rad - T.yaw_rad), 0.0, 1e-12);
}

double BruteForceAssignment(const std::vector<double>& cost, int rows, int cols) {
  // Enumerate injective maps of the smaller side into the larger one.
  const bool transpose = rows > cols;
  const int n = transpose ? cols : rows, m = transpose ? rows : cols;
  auto c = [&](int i, int j) {
    return transpose ? cost[std::size_t(j) * cols + i] : cost[std::size_t(i) * cols + j];
  };
  std::vector<int> perm(m);
  std::iota(perm.begin(), perm.end(), 0);
  double best = std::numeric_limits<double>::infinity();
  do {  // permutations of m columns; the first n are used (repeats are harmless)
    double sum = 0.0;
    for (int i = 0; i < n; ++i) sum += c(i, perm[i]);
    best = std::min(best, sum);
  } while (std::next_permutation(perm.begin(), perm.end()));
  return best;
}

TEST(Assignment, MatchesBruteForceOnRandomRectangularMatrices) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  std::uniform_int_distribution<int> size(1, 6);
  for (int trial = 0; trial < 300; ++trial) {
    const int rows = size(rng), cols = size(rng);
    std::vector<double> cost(std::size_t(rows) * cols);
    for (auto& x : cost) x = trial % 3 == 0 ? std::round(u(rng)) : u(rng);  // ties too
    const std::vector<int> col = SolveAssignment(cost, rows, cols);
    ASSERT_EQ(static_cast<int>(col.size()), rows);
    std::vector<char> used(cols, 0);
    double sum = 0.0;
    int assigned = 0;
    for (int i = 0; i < rows; ++i) {
      if (col[i] < 0) continue;
      ASSERT_LT(col[i], cols);
      ASSERT_FALSE(used[col[i]]);
      used[col[i]] = 1;
      sum += cost[std::size_t(i) * cols + col[i]];
      ++assigned;
    }
    EXPECT_EQ(assigned, std::min(rows, cols));
    EXPECT_NEAR(sum, BruteForceAssignment(cost, rows, cols), 1e-9) << rows << "x" << cols;
  }
}

TEST(Assignment, EmptyAndRejectsBadShape) {
  EXPECT_TRUE(SolveAssignment({}, 0, 3).empty());
  EXPECT_EQ(SolveAssignment({}, 2, 0), (std::vector<int>{-1, -1}));
  EXPECT_THROW(SolveAssignment({1.0, 2.0}, 3, 1), std::invalid_argument);
}

}  // namespace
}  // namespace draco::objects
