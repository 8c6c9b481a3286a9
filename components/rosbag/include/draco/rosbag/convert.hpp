// Conversion of decoded ROS 1 messages (RosValue, looked up by field name) into draco's
// sensor messages. Each function throws DecodeError naming the field that is missing or
// inconsistent. No OpenCV or rosbag types in this header.
#pragma once

#include <string>

#include "draco/msgs/sensors.hpp"
#include "draco/rosbag/ros_message.hpp"

namespace draco::rosbag {

struct ConvertOptions {
  // Undo the Oculus driver's gamma: out = (in / 255)^(255 / gamma) * 255, with gamma from
  // fire_msg.gamma (skipped when the field is absent, 0 or 255).
  bool linearize_gamma = true;
  // The vehicle recordings use x forward, y right, z down (body) and north-east-down (world),
  // with sonar bearings positive to starboard. draco uses x forward, y left, z up and
  // counter-clockwise angles: y and z (and pitch, yaw, bearings) change sign, and the sonar
  // columns are reversed so bearings increase. Set false for data already in that frame.
  bool frd_to_flu = true;
  // Not in the ping message; Oculus M750d at 750 kHz: 20 deg.
  double vertical_aperture_rad = 0.3490658503988659;
  // DVL samples with any |velocity component| above this (e.g. the RTI "bad" value 88.888)
  // or not finite are marked invalid.
  double dvl_max_valid_speed_mps = 5.0;
};

// sonar_oculus/OculusPing (ping = sensor_msgs/CompressedImage, JPEG or PNG, 8-bit) or
// OculusPingUncompressed (ping = sensor_msgs/Image, mono8/8UC1); rows = range bins,
// columns = beams; bearings in hundredths of a degree.
msgs::SonarPing ToSonarPing(const RosValue& msg, double time_s, const ConvertOptions& options);
// sensor_msgs/Imu: roll, pitch, yaw (Z-Y-X) from the orientation quaternion, yaw rate from
// angular_velocity.z.
msgs::Ahrs ToAhrs(const RosValue& msg, double time_s, const ConvertOptions& options);
// rti_dvl/DVL: body velocity and altitude (<= 0 read as unknown).
msgs::DvlVelocity ToDvlVelocity(const RosValue& msg, double time_s, const ConvertOptions& options);
// bar30_depth/Depth: depth, positive down.
msgs::Depth ToDepth(const RosValue& msg, double time_s);
// geometry_msgs/PoseStamped: position and roll, pitch, yaw.
msgs::GroundTruthPose ToGroundTruthPose(const RosValue& msg, double time_s,
                                        const ConvertOptions& options);

// Euler angles (roll about x, then pitch about y, then yaw about z: R = Rz Ry Rx) of a unit
// quaternion; the quaternion is normalised first. Throws DecodeError for a zero quaternion.
struct Euler {
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  double yaw_rad = 0.0;
};
Euler EulerFromQuaternion(double x, double y, double z, double w, const std::string& field);

}  // namespace draco::rosbag
