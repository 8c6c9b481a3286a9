// Sensor messages shared by the sonar reader, the simulator, the ROS bag reader and
// local SLAM. Plain structs: no runtime, no Eigen fixed-size members (they cross threads
// inside shared_ptr<const T>), SI units in field names, times in mission seconds.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace draco::msgs {

// One forward-looking sonar ping as a polar image.
// intensity is row-major: row = range bin (range of row i is (i + 1) * range_resolution_m),
// column = beam; bearings_rad[beam] is the beam's azimuth in the sensor frame
// (x forward, y left, positive counter-clockwise).
struct SonarPing {
  double time_s = 0.0;
  std::uint32_t ping_id = 0;
  int num_ranges = 0;
  int num_beams = 0;
  double range_resolution_m = 0.0;
  std::vector<float> bearings_rad;      // size num_beams, increasing
  std::vector<std::uint8_t> intensity;  // size num_ranges * num_beams
  double vertical_aperture_rad = 0.0;   // 0 when unknown

  double MaxRangeM() const { return num_ranges * range_resolution_m; }
  std::uint8_t At(int range_bin, int beam) const {
    return intensity[static_cast<std::size_t>(range_bin) * num_beams + beam];
  }
};

// Doppler velocity log: body-frame velocity (x forward, y left, z up).
struct DvlVelocity {
  double time_s = 0.0;
  std::array<double, 3> velocity_body_mps{0.0, 0.0, 0.0};
  double altitude_m = -1.0;  // < 0 when unknown
  bool valid = true;         // false on a bottom-lock dropout
};

// Attitude and heading reference: orientation of the body in the navigation frame.
// yaw is counter-clockwise from the navigation x axis.
struct Ahrs {
  double time_s = 0.0;
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
  double yaw_rate_radps = 0.0;
};

struct Depth {
  double time_s = 0.0;
  double depth_m = 0.0;  // positive down
};

// Ground-truth 6-DoF pose of the body in the world frame (when the recording has it).
struct GroundTruthPose {
  double time_s = 0.0;
  std::array<double, 3> position_m{0.0, 0.0, 0.0};
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
};

}  // namespace draco::msgs
