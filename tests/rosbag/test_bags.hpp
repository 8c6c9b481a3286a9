// The test bags, written by write_test_bags.py (the official ROS 1 writer) on first use in
// this test process, into a folder of its own (CTest may run test processes in parallel),
// removed when the process exits. Known values are recomputed here as the script does.
#pragma once

#include <cmath>
#include <string>

namespace draco::rosbag::testbags {

constexpr double kBagStart = 1600000000.0;
constexpr double kReceiptDelay = 0.005;  // receipt time = header stamp + this
constexpr int kNumRanges = 48;
constexpr int kNumBeams = 32;
constexpr double kRangeResolution = 0.05;
constexpr double kGamma = 127;

inline int Pattern(int ping, int r, int c) {
  return (40 * (r / 8) + 25 * (c / 8) + 30 * ping) % 256;
}
inline double BearingHundredths(int c) { return std::round(-6500 + c * 13000.0 / (kNumBeams - 1)); }

// Path of a bag written by the script (e.g. "full.bag"); writes them all on first call.
std::string Path(const std::string& name);

}  // namespace draco::rosbag::testbags
