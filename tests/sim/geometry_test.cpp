// Ray intersections against hand-computed values.
#include <gtest/gtest.h>

#include "draco/sim/geometry.hpp"

namespace draco::sim {
namespace {

TEST(Geometry, RayCircleHitsFrontFaceWithOutwardNormal) {
  // Ray along +x from the origin; circle of radius 1 at (5, 0): enters at 4, leaves at 6.
  RayInterval iv;
  ASSERT_TRUE(IntersectRayCircle({0, 0}, {1, 0}, {5, 0}, 1.0, &iv));
  EXPECT_NEAR(iv.s_in, 4.0, 1e-12);
  EXPECT_NEAR(iv.s_out, 6.0, 1e-12);
  EXPECT_NEAR(iv.normal_in.x, -1.0, 1e-12);
  EXPECT_NEAR(iv.normal_in.y, 0.0, 1e-12);
}

TEST(Geometry, RayCircleOffsetChord) {
  // Circle radius 1 at (5, 0.6): chord half-length sqrt(1 - 0.36) = 0.8 -> s in [4.2, 5.8];
  // entry point (4.2, 0) has normal (4.2 - 5, 0 - 0.6) = (-0.8, -0.6).
  RayInterval iv;
  ASSERT_TRUE(IntersectRayCircle({0, 0}, {1, 0}, {5, 0.6}, 1.0, &iv));
  EXPECT_NEAR(iv.s_in, 4.2, 1e-12);
  EXPECT_NEAR(iv.s_out, 5.8, 1e-12);
  EXPECT_NEAR(iv.normal_in.x, -0.8, 1e-12);
  EXPECT_NEAR(iv.normal_in.y, -0.6, 1e-12);
}

TEST(Geometry, RayCircleMissesAndBehind) {
  RayInterval iv;
  EXPECT_FALSE(IntersectRayCircle({0, 0}, {1, 0}, {5, 1.01}, 1.0, &iv));
  EXPECT_FALSE(IntersectRayCircle({0, 0}, {1, 0}, {-5, 0}, 1.0, &iv));
  // Origin inside: s_in negative, s_out positive.
  ASSERT_TRUE(IntersectRayCircle({0, 0}, {0, 1}, {0, 0.5}, 1.0, &iv));
  EXPECT_NEAR(iv.s_in, -0.5, 1e-12);
  EXPECT_NEAR(iv.s_out, 1.5, 1e-12);
}

TEST(Geometry, RayBoxAtAnAngle) {
  // Box 2 x 2 centred at (4, 0), axis-aligned; a ray from the origin at 45 deg misses it
  // (at x = 3 it is at y = 3), one at atan(0.25) enters the face x = 3 at y = 0.75.
  const auto box = BoxVertices({4, 0}, 2.0, 2.0, 0.0);
  RayInterval iv;
  const double a = std::atan(0.25);
  ASSERT_TRUE(IntersectRayConvexPolygon({0, 0}, {std::cos(a), std::sin(a)}, box, &iv));
  EXPECT_NEAR(iv.s_in, 3.0 / std::cos(a), 1e-12);
  // It leaves through the face y = 1 (at x = 4), before reaching x = 5 (where y = 1.25).
  EXPECT_NEAR(iv.s_out, 1.0 / std::sin(a), 1e-12);
  EXPECT_NEAR(iv.normal_in.x, -1.0, 1e-12);
  EXPECT_NEAR(iv.normal_in.y, 0.0, 1e-12);
  EXPECT_FALSE(IntersectRayConvexPolygon({0, 0}, {std::sqrt(0.5), std::sqrt(0.5)}, box, &iv));
}

TEST(Geometry, RotatedBoxFace) {
  // Box 4 long x 2 wide at (10, 0) rotated 90 deg: its faces facing the origin are at
  // x = 9 (width 2 along x) -> a ray along +x enters at 9 and leaves at 11.
  const auto box = BoxVertices({10, 0}, 4.0, 2.0, M_PI / 2);
  RayInterval iv;
  ASSERT_TRUE(IntersectRayConvexPolygon({0, 0}, {1, 0}, box, &iv));
  EXPECT_NEAR(iv.s_in, 9.0, 1e-9);
  EXPECT_NEAR(iv.s_out, 11.0, 1e-9);
}

TEST(Geometry, RaySegmentNormalFacesTheRay) {
  RayInterval iv;
  ASSERT_TRUE(IntersectRaySegment({0, 0}, {1, 0}, {3, -1}, {3, 1}, &iv));
  EXPECT_NEAR(iv.s_in, 3.0, 1e-12);
  EXPECT_NEAR(iv.normal_in.x, -1.0, 1e-12);
  ASSERT_TRUE(IntersectRaySegment({6, 0}, {-1, 0}, {3, -1}, {3, 1}, &iv));
  EXPECT_NEAR(iv.s_in, 3.0, 1e-12);
  EXPECT_NEAR(iv.normal_in.x, 1.0, 1e-12);
  EXPECT_FALSE(IntersectRaySegment({0, 0}, {1, 0}, {3, 0.5}, {3, 1}, &iv));
}

TEST(Geometry, WrapAngleAndConvexity) {
  EXPECT_NEAR(WrapAngle(3 * M_PI / 2), -M_PI / 2, 1e-12);
  EXPECT_NEAR(WrapAngle(-3 * M_PI / 2), M_PI / 2, 1e-12);
  EXPECT_TRUE(IsConvex({{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
  EXPECT_FALSE(IsConvex({{0, 0}, {2, 0}, {1, 0.5}, {2, 2}, {0, 2}}));
  EXPECT_GT(SignedArea({{0, 0}, {1, 0}, {1, 1}, {0, 1}}), 0.0);
}

}  // namespace
}  // namespace draco::sim
