// The PCL and MRPT registration back ends of AlignIcp (icp.hpp), one translation unit each
// (pcl_icp.cpp, pcl_gicp.cpp, pcl_ndt.cpp, mrpt_icp.cpp). Private to draco_icp; no PCL or
// MRPT in this header.
#pragma once

#include "draco/icp/icp.hpp"

namespace draco::icp::detail {

// What a back end answers; AlignIcp computes the rest (covariance, overlap, final validity)
// from the pose.
struct BackendAnswer {
  msgs::Pose2 T_target_source;  // projected to SE(2)
  bool valid = false;           // the back end produced a finite pose
  bool converged = false;       // its convergence test passed before max_iterations
  int iterations = 0;
};

BackendAnswer AlignPclIcp(const Cloud2& source, IcpTarget& target,
                          const msgs::Pose2& initial_T_target_source, const IcpOptions& options);
BackendAnswer AlignPclGicp(const Cloud2& source, IcpTarget& target,
                           const msgs::Pose2& initial_T_target_source, const IcpOptions& options);
BackendAnswer AlignPclNdt(const Cloud2& source, IcpTarget& target,
                          const msgs::Pose2& initial_T_target_source, const IcpOptions& options);
BackendAnswer AlignMrptIcp(const Cloud2& source, IcpTarget& target,
                           const msgs::Pose2& initial_T_target_source, const IcpOptions& options);

}  // namespace draco::icp::detail
