// Eigen heap memory crosses the boundary between draco and libceres (built by Debian, without
// sanitizers): both sides must allocate and free it the same way. Eigen 3.4 uses plain
// malloc/free where malloc is already 16-byte aligned (EIGEN_MALLOC_ALREADY_ALIGNED), and a
// handmade aligned allocator (original pointer stored before the block) elsewhere. Under
// AddressSanitizer Eigen assumes the latter unless told otherwise; the sanitizer build defines
// EIGEN_MALLOC_ALREADY_ALIGNED=1 (cmake/CompilerOptions.cmake), which these tests justify.
#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "se2_cost.hpp"

// Plain malloc is aligned enough for Eigen only while Eigen wants 16 bytes (no AVX).
#if EIGEN_MALLOC_ALREADY_ALIGNED
static_assert(EIGEN_DEFAULT_ALIGN_BYTES <= 16,
              "EIGEN_MALLOC_ALREADY_ALIGNED=1 needs 16-byte Eigen alignment (no -mavx)");
#endif

namespace draco::pose_graph {
namespace {

bool Aligned16(const void* p) { return reinterpret_cast<std::uintptr_t>(p) % 16 == 0; }

// The assumption behind EIGEN_MALLOC_ALREADY_ALIGNED: malloc (glibc's, or the sanitizer's that
// replaces it) returns 16-byte aligned blocks of every size Eigen asks for.
TEST(EigenHeap, MallocIsSixteenByteAligned) {
  std::vector<void*> blocks;
  for (std::size_t size = 16; size <= 4096; ++size) blocks.push_back(std::malloc(size));
  for (std::size_t size = 4096; size <= (std::size_t{1} << 24); size = size * 3 / 2 + 8) {
    blocks.push_back(std::malloc(size));
  }
  std::size_t misaligned = 0;
  for (void* p : blocks) {
    ASSERT_NE(p, nullptr);
    if (!Aligned16(p)) ++misaligned;
    std::free(p);
  }
  EXPECT_EQ(misaligned, 0u);
  for (int n = 2; n < 300; n += 7) {
    const Eigen::MatrixXd m = Eigen::MatrixXd::Constant(n, n, 1.0);
    EXPECT_TRUE(Aligned16(m.data())) << n;
  }
}

// Both directions through libceres: matrices draco allocated are freed by libceres (Probe
// clears and resizes the results it is given), and the ones libceres allocated are freed by
// draco (the results' destructor here).
TEST(EigenHeap, MatricesCrossLibceresBothWays) {
  internal::Pose2Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds{&manifold};
  const internal::PriorCost cost({1.0, 2.0, -2.5}, Matrix3{1, 0, 0, 0, 1, 0, 0, 0, 1});
  ceres::GradientChecker checker(&cost, &manifolds, ceres::NumericDiffOptions{});
  const double x[3] = {0.3, -0.4, 0.5};
  const double* params[1] = {x};
  for (int round = 0; round < 3; ++round) {
    ceres::GradientChecker::ProbeResults results;
    results.residuals = ceres::Vector::Zero(17);
    results.jacobians.assign(4, ceres::Matrix::Zero(5, 9));
    results.local_jacobians.assign(2, ceres::Matrix::Zero(11, 2));
    results.numeric_jacobians.assign(3, ceres::Matrix::Zero(1, 7));
    results.local_numeric_jacobians.assign(1, ceres::Matrix::Zero(6, 6));
    EXPECT_TRUE(checker.Probe(params, 1e-6, &results)) << results.error_log;
    ASSERT_EQ(results.jacobians.size(), 1u);
    EXPECT_EQ(results.jacobians[0].rows(), 3);
    EXPECT_EQ(results.residuals.size(), 3);
  }
}

}  // namespace
}  // namespace draco::pose_graph
