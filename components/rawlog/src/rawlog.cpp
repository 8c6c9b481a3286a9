// MRPT rawlogs through mrpt::obs (rawlog.hpp).
#include "draco/rawlog/rawlog.hpp"

#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationRobotPose.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <stdexcept>

namespace draco::rawlog {
namespace {

mrpt::poses::CPose3D To3D(const msgs::Pose2& T) {
  return mrpt::poses::CPose3D(T.x_m, T.y_m, 0.0, T.yaw_rad, 0.0, 0.0);
}
msgs::Pose2 From3D(const mrpt::poses::CPose3D& p) { return {p.x(), p.y(), p.yaw()}; }

mrpt::serialization::CSerializable::Ptr ToMrpt(const Entry& entry) {
  const auto stamp = mrpt::Clock::fromDouble(EntryTime(entry));
  if (const auto* o = std::get_if<Odometry>(&entry)) {
    auto obs = std::make_shared<mrpt::obs::CObservationOdometry>();
    obs->sensorLabel = "ODOMETRY";
    obs->timestamp = stamp;
    obs->odometry =
        mrpt::poses::CPose2D(o->T_odom_body.x_m, o->T_odom_body.y_m, o->T_odom_body.yaw_rad);
    return obs;
  }
  if (const auto* s = std::get_if<RangeScan>(&entry)) {
    if (s->ranges_m.size() != s->valid.size()) {
      throw std::invalid_argument("rawlog: a range scan has " + std::to_string(s->ranges_m.size()) +
                                  " ranges but " + std::to_string(s->valid.size()) +
                                  " valid flags");
    }
    auto obs = std::make_shared<mrpt::obs::CObservation2DRangeScan>();
    obs->sensorLabel = "SONAR";
    obs->timestamp = stamp;
    obs->aperture = static_cast<float>(s->aperture_rad);
    obs->rightToLeft = true;
    obs->maxRange = static_cast<float>(s->max_range_m);
    obs->sensorPose = To3D(s->T_body_sensor);
    obs->resizeScan(s->ranges_m.size());
    for (std::size_t i = 0; i < s->ranges_m.size(); ++i) {
      obs->setScanRange(i, s->ranges_m[i]);
      obs->setScanRangeValidity(i, s->valid[i] != 0);
    }
    return obs;
  }
  const auto& e = std::get<PoseEstimate>(entry);
  auto obs = std::make_shared<mrpt::obs::CObservationRobotPose>();
  obs->sensorLabel = "ESTIMATE";
  obs->timestamp = stamp;
  obs->pose.mean = To3D(e.T_map_body);
  return obs;
}

// One MRPT observation as an entry; false for other types.
bool FromMrpt(const mrpt::obs::CObservation& o, std::vector<Entry>* out) {
  const double t = mrpt::Clock::toDouble(o.timestamp);
  if (const auto* odo = dynamic_cast<const mrpt::obs::CObservationOdometry*>(&o)) {
    out->push_back(Odometry{t, {odo->odometry.x(), odo->odometry.y(), odo->odometry.phi()}});
    return true;
  }
  if (const auto* scan = dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(&o)) {
    RangeScan s;
    s.time_s = t;
    s.T_body_sensor = From3D(scan->sensorPose);
    s.aperture_rad = scan->aperture;
    s.max_range_m = scan->maxRange;
    const std::size_t n = scan->getScanSize();
    s.ranges_m.resize(n);
    s.valid.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      // Left-to-right scans reversed, so beam 0 is always the rightmost.
      const std::size_t j = scan->rightToLeft ? i : n - 1 - i;
      s.ranges_m[j] = scan->getScanRange(i);
      s.valid[j] = scan->getScanRangeValidity(i) ? 1 : 0;
    }
    out->push_back(std::move(s));
    return true;
  }
  if (const auto* pose = dynamic_cast<const mrpt::obs::CObservationRobotPose*>(&o)) {
    out->push_back(PoseEstimate{t, From3D(pose->pose.mean)});
    return true;
  }
  return false;
}

}  // namespace

double EntryTime(const Entry& entry) {
  return std::visit([](const auto& e) { return e.time_s; }, entry);
}

RangeScan ScanFromPoints(double time_s, const std::vector<msgs::Point2>& points, int beams,
                         double aperture_rad, double max_range_m) {
  if (beams < 2) throw std::invalid_argument("rawlog scan: beams must be at least 2");
  if (!(aperture_rad > 0.0) || !(max_range_m > 0.0)) {
    throw std::invalid_argument("rawlog scan: aperture_rad and max_range_m must be positive");
  }
  RangeScan s;
  s.time_s = time_s;
  s.aperture_rad = aperture_rad;
  s.max_range_m = max_range_m;
  s.ranges_m.assign(static_cast<std::size_t>(beams), static_cast<float>(max_range_m));
  s.valid.assign(static_cast<std::size_t>(beams), 0);
  const double step = aperture_rad / (beams - 1);
  for (const auto& p : points) {
    const double r = std::hypot(p.x_m, p.y_m);
    if (!(r > 0.0) || r > max_range_m) continue;
    const double i = std::round((std::atan2(p.y_m, p.x_m) + 0.5 * aperture_rad) / step);
    if (!(i >= 0.0 && i < beams)) continue;
    const auto b = static_cast<std::size_t>(i);
    if (!s.valid[b] || r < s.ranges_m[b]) {
      s.ranges_m[b] = static_cast<float>(r);
      s.valid[b] = 1;
    }
  }
  return s;
}

std::vector<msgs::Point2> ScanPoints(const RangeScan& s) {
  std::vector<msgs::Point2> out;
  const std::size_t n = s.ranges_m.size();
  if (n < 2) return out;
  const double step = s.aperture_rad / static_cast<double>(n - 1);
  for (std::size_t i = 0; i < n && i < s.valid.size(); ++i) {
    if (!s.valid[i]) continue;
    const double a = -0.5 * s.aperture_rad + static_cast<double>(i) * step;
    out.push_back({s.ranges_m[i] * std::cos(a), s.ranges_m[i] * std::sin(a)});
  }
  return out;
}

void WriteRawlog(const std::string& path, const std::vector<Entry>& entries) {
  mrpt::obs::CRawlog log;
  for (const auto& e : entries) log.insert(ToMrpt(e));
  bool ok = false;
  try {
    ok = log.saveToRawLogFile(path);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write rawlog " + path + ": " + e.what());
  }
  if (!ok) throw std::runtime_error("cannot write rawlog " + path);
}

std::vector<Entry> ReadRawlog(const std::string& path, ReadStats* stats) {
  if (!std::filesystem::is_regular_file(path)) {
    throw std::runtime_error(path + ": no such rawlog");
  }
  mrpt::obs::CRawlog log;
  bool ok = false;
  try {
    ok = log.loadFromRawLogFile(path, true);
  } catch (const std::exception& e) {
    throw std::runtime_error(path +
                             ": not an MRPT rawlog: " + std::string(e.what()).substr(0, 300));
  }
  if (!ok) throw std::runtime_error(path + ": not an MRPT rawlog (MRPT could not read it)");
  ReadStats local;
  ReadStats& st = stats != nullptr ? *stats : local;
  std::vector<Entry> out;
  // The pair format's odometry is increments (CActionRobotMovement2D): accumulated from the
  // origin.
  mrpt::poses::CPose2D odometry;
  for (std::size_t i = 0; i < log.size(); ++i) {
    switch (log.getType(i)) {
      case mrpt::obs::CRawlog::etObservation:
        if (!FromMrpt(*log.getAsObservation(i), &out)) ++st.skipped;
        break;
      case mrpt::obs::CRawlog::etSensoryFrame:
        for (const auto& o : *log.getAsObservations(i)) {
          if (!o || !FromMrpt(*o, &out)) ++st.skipped;
        }
        break;
      case mrpt::obs::CRawlog::etActionCollection: {
        const auto actions = log.getAsAction(i);
        const auto move = actions->getBestMovementEstimation();
        if (!move || !move->poseChange) {
          ++st.skipped;
          break;
        }
        odometry = odometry + move->poseChange->getMeanVal();
        out.push_back(Odometry{mrpt::Clock::toDouble(move->timestamp),
                               {odometry.x(), odometry.y(), odometry.phi()}});
        break;
      }
      default:
        ++st.skipped;
        break;
    }
  }
  if (log.size() == 0) {
    throw std::runtime_error(path + ": not an MRPT rawlog (no MRPT object in it)");
  }
  return out;
}

}  // namespace draco::rawlog
