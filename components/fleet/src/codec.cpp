// Payload layouts: docs/fleet.md "Messages and their encoding".
#include "draco/fleet/codec.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

#include "bits.hpp"
#include "points.hpp"

namespace draco::fleet {

namespace {

using bits::BitReader;
using bits::BitWriter;
using msgs::FleetKind;
using points::GridPoint;
using points::PointCoding;

// Exp-Golomb orders of fields coded with a fixed order.
constexpr int kRobotOrder = 2;
constexpr int kSeqOrder = 4;
constexpr int kTimeOrder = 12;
constexpr int kVersionOrder = 3;
constexpr int kCountOrder = 2;
constexpr int kIndexOrder = 8;
constexpr int kOrderBits = 5;  // per-message exp-Golomb orders 0..31
constexpr int kMaxOrder = 31;

// Loop covariance: log2 sigma in steps of 1/16 over [-24, 40), correlations in steps of 1/511.
constexpr double kLogSigmaStep = 1.0 / 16.0;
constexpr double kLogSigmaMin = -24.0;
constexpr int kLogSigmaBits = 10;
constexpr int kCorrelationScale = 511;
constexpr int kCorrelationBits = 10;
constexpr int kOverlapBits = 8;
constexpr int kObjectYawBits = 8;
// A map's absolute heading: a presence bit, then 12 bits over [0, 2 pi) (0.09 deg).
constexpr int kHeadingBits = 12;

// Largest |v| the decoders accept for a flags / id / version field.
constexpr std::uint64_t kMaxU32 = 0xffffffffull;

std::string Fmt(const char* format, auto... args) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), format, args...);
  return buf;
}

double WrapPi(double a) {
  a = std::remainder(a, 2.0 * std::numbers::pi);  // [-pi, pi]
  return a;
}

double HalfTurn(double a) {  // into [0, pi)
  a = std::fmod(a, std::numbers::pi);
  if (a < 0) a += std::numbers::pi;
  if (a >= std::numbers::pi) a = 0.0;
  return a;
}

void CheckOptions(const CodecOptions& o) {
  for (const double step :
       {o.position_step_m, o.size_step_m, o.yaw_step_rad, o.point_step_m, o.time_step_s})
    if (!(std::isfinite(step) && step > 0.0))
      throw std::invalid_argument("fleet codec: quantisation steps must be finite and positive");
}

// ---------------------------------------------------------------------------------------
// Encoding

class Encoder {
 public:
  Encoder(FleetKind kind, const CodecOptions& o) : kind_(kind), o_(o) { CheckOptions(o); }

  [[noreturn]] void Throw(const std::string& what) const {
    throw std::invalid_argument(std::string(msgs::FleetKindName(kind_)) + ": " + what);
  }

  std::int64_t Quantise(double v, double step, double bound, const char* field) const {
    if (!std::isfinite(v)) Throw(Fmt("%s is not finite", field));
    if (std::abs(v) > bound) Throw(Fmt("%s %g exceeds the bound %g", field, v, bound));
    return std::llround(v / step);
  }
  std::int64_t Coordinate(double v, double step, const char* field) const {
    return Quantise(v, step, b_.max_abs_coordinate_m, field);
  }
  std::int64_t Time(double t, const char* field) const {
    return Quantise(t, o_.time_step_s, b_.max_time_s, field);
  }
  std::int64_t Yaw(double yaw, const char* field) const {
    if (!std::isfinite(yaw)) Throw(Fmt("%s is not finite", field));
    return std::llround(WrapPi(yaw) / o_.yaw_step_rad);
  }
  void Robot(int id, const char* field) {
    if (id < 0 || id > b_.max_robot_id)
      Throw(Fmt("%s %d outside [0, %d]", field, id, b_.max_robot_id));
    w.PutExpGolomb(static_cast<std::uint64_t>(id), kRobotOrder);
  }
  void Count(std::size_t n, int bound, const char* field) {
    if (n > static_cast<std::size_t>(bound))
      Throw(Fmt("%zu %s exceed the bound %d", n, field, bound));
    w.PutExpGolomb(n, kCountOrder);
  }
  void Index(int index, const char* field) {
    if (index < 0 || index > b_.max_keyframes)
      Throw(Fmt("%s %d outside [0, %d]", field, index, b_.max_keyframes));
    w.PutExpGolomb(static_cast<std::uint64_t>(index), kIndexOrder);
  }
  void Header(const msgs::FleetHeader& h) {
    Robot(h.robot_id, "robot_id");
    w.Put(h.incarnation, 32);
    w.PutExpGolomb(h.seq, kSeqOrder);
    w.PutSignedExpGolomb(Time(h.time_s, "header time"), kTimeOrder);
  }
  void Pose(const msgs::Pose2& p, const char* field) {
    const std::string f(field);
    w.PutSignedExpGolomb(Coordinate(p.x_m, o_.position_step_m, (f + ".x").c_str()), 12);
    w.PutSignedExpGolomb(Coordinate(p.y_m, o_.position_step_m, (f + ".y").c_str()), 12);
    w.PutSignedExpGolomb(Yaw(p.yaw_rad, (f + ".yaw").c_str()), 10);
  }
  // Values with a per-message order (5 bits) chosen to minimise their size.
  void Adaptive(const std::vector<std::uint64_t>& values) {
    const int k = bits::BestExpGolombOrder(values, kMaxOrder);
    w.Put(static_cast<std::uint64_t>(k), kOrderBits);
    for (const auto v : values) w.PutExpGolomb(v, k);
  }
  std::vector<std::uint8_t> Finish() { return w.bytes(); }

  BitWriter w;
  FleetKind kind_;
  CodecOptions o_;
  Bounds b_;
};

// ---------------------------------------------------------------------------------------
// Decoding

class Decoder {
 public:
  Decoder(FleetKind kind, const std::vector<std::uint8_t>& bytes, const CodecOptions& o,
          const Bounds& b)
      : r(bytes), kind_(kind), o_(o), b_(b) {}

  // Records the first error; always returns false.
  bool Fail(const std::string& what) {
    if (error_.empty()) error_ = std::string(msgs::FleetKindName(kind_)) + ": " + what;
    return false;
  }
  bool Truncated(const char* field) {
    return Fail(Fmt("truncated or malformed at %s (bit %zu)", field, r.position_bits()));
  }
  DecodeResult Result() const {
    DecodeResult res;
    res.ok = error_.empty();
    res.error = error_;
    return res;
  }
  bool Options() {
    for (const double step :
         {o_.position_step_m, o_.size_step_m, o_.yaw_step_rad, o_.point_step_m, o_.time_step_s})
      if (!(std::isfinite(step) && step > 0.0))
        return Fail("codec options: quantisation steps must be finite and positive");
    return true;
  }

  bool U(int num_bits, std::uint64_t* v, const char* field) {
    return r.Get(num_bits, v) || Truncated(field);
  }
  bool EG(int k, std::uint64_t* v, const char* field) {
    return r.GetExpGolomb(k, v) || Truncated(field);
  }
  bool SEG(int k, std::int64_t* v, const char* field) {
    return r.GetSignedExpGolomb(k, v) || Truncated(field);
  }
  bool U32(int k, std::uint32_t* v, const char* field) {
    std::uint64_t u = 0;
    if (!EG(k, &u, field)) return false;
    if (u > kMaxU32) return Fail(Fmt("%s %llu exceeds 32 bits", field, (unsigned long long)u));
    *v = static_cast<std::uint32_t>(u);
    return true;
  }
  bool Order(int* k, const char* field) {
    std::uint64_t u = 0;
    if (!U(kOrderBits, &u, field)) return false;
    *k = static_cast<int>(u);
    return true;
  }
  // A quantised value times step, within |bound| (+ half a step of rounding).
  bool Scaled(std::int64_t q, double step, double bound, double* v, const char* field) {
    const double x = static_cast<double>(q) * step;
    if (!std::isfinite(x) || std::abs(x) > bound + step)
      return Fail(Fmt("%s %g exceeds the bound %g", field, x, bound));
    *v = x;
    return true;
  }
  bool Coordinate(std::int64_t q, double step, double* v, const char* field) {
    return Scaled(q, step, b_.max_abs_coordinate_m, v, field);
  }
  bool Time(std::int64_t q, double* t, const char* field) {
    return Scaled(q, o_.time_step_s, b_.max_time_s, t, field);
  }
  bool Yaw(std::int64_t q, double* yaw, const char* field) {
    return Scaled(q, o_.yaw_step_rad, std::numbers::pi, yaw, field);
  }
  bool Robot(int* id, const char* field) {
    std::uint64_t u = 0;
    if (!EG(kRobotOrder, &u, field)) return false;
    if (u > static_cast<std::uint64_t>(std::max(0, b_.max_robot_id)))
      return Fail(Fmt("%s %llu outside [0, %d]", field, (unsigned long long)u, b_.max_robot_id));
    *id = static_cast<int>(u);
    return true;
  }
  bool Count(int bound, std::size_t* n, const char* field) {
    std::uint64_t u = 0;
    if (!EG(kCountOrder, &u, field)) return false;
    if (u > static_cast<std::uint64_t>(std::max(0, bound)))
      return Fail(Fmt("%llu %s exceed the bound %d", (unsigned long long)u, field, bound));
    *n = static_cast<std::size_t>(u);
    return true;
  }
  bool IndexValue(std::uint64_t u, int* index, const char* field) {
    if (u > static_cast<std::uint64_t>(std::max(0, b_.max_keyframes)))
      return Fail(Fmt("%s %llu outside [0, %d]", field, (unsigned long long)u, b_.max_keyframes));
    *index = static_cast<int>(u);
    return true;
  }
  bool Index(int* index, const char* field) {
    std::uint64_t u = 0;
    return EG(kIndexOrder, &u, field) && IndexValue(u, index, field);
  }
  bool Header(msgs::FleetHeader* h) {
    std::uint64_t inc = 0;
    std::int64_t t = 0;
    return Robot(&h->robot_id, "robot_id") && U(32, &inc, "incarnation") &&
           (h->incarnation = static_cast<std::uint32_t>(inc), true) &&
           U32(kSeqOrder, &h->seq, "seq") && SEG(kTimeOrder, &t, "header time") &&
           Time(t, &h->time_s, "header time");
  }
  bool Pose(msgs::Pose2* p, const char* field) {
    std::int64_t qx = 0, qy = 0, qyaw = 0;
    return SEG(12, &qx, field) && SEG(12, &qy, field) && SEG(10, &qyaw, field) &&
           Coordinate(qx, o_.position_step_m, &p->x_m, field) &&
           Coordinate(qy, o_.position_step_m, &p->y_m, field) && Yaw(qyaw, &p->yaw_rad, field);
  }
  bool End() {
    if (!r.ok()) return Truncated("end");
    if (!r.AtPaddedEnd())
      return Fail(Fmt("%zu bits left over after the message", r.remaining_bits()));
    return true;
  }

  BitReader r;
  FleetKind kind_;
  CodecOptions o_;
  Bounds b_;
  std::string error_;
};

// ---------------------------------------------------------------------------------------
// Loop covariance: 3 log-quantised sigmas and 3 quantised correlations.

struct PackedCovariance {
  std::array<std::uint32_t, 3> log_sigma{};  // kLogSigmaBits each
  std::array<std::int32_t, 3> rho{};         // xy, x-yaw, y-yaw in [-511, 511]
};

// Cholesky test of a symmetric 3x3 matrix.
bool PositiveDefinite(const msgs::Covariance3& c) {
  const double l00 = c[0];
  if (!(l00 > 0.0)) return false;
  const double a = std::sqrt(l00);
  const double l10 = c[3] / a, l20 = c[6] / a;
  const double d1 = c[4] - l10 * l10;
  if (!(d1 > 0.0)) return false;
  const double b = std::sqrt(d1);
  const double l21 = (c[7] - l20 * l10) / b;
  const double d2 = c[8] - l20 * l20 - l21 * l21;
  return d2 > 0.0 && std::isfinite(d2);
}

msgs::Covariance3 Unpack(const PackedCovariance& p) {
  std::array<double, 3> s{};
  for (int i = 0; i < 3; ++i)
    s[i] = std::exp2(kLogSigmaMin + kLogSigmaStep * static_cast<double>(p.log_sigma[i]));
  const double rxy = p.rho[0] / double{kCorrelationScale};
  const double rxt = p.rho[1] / double{kCorrelationScale};
  const double ryt = p.rho[2] / double{kCorrelationScale};
  return {s[0] * s[0],       rxy * s[0] * s[1], rxt * s[0] * s[2], rxy * s[0] * s[1], s[1] * s[1],
          ryt * s[1] * s[2], rxt * s[0] * s[2], ryt * s[1] * s[2], s[2] * s[2]};
}

PackedCovariance Pack(const msgs::Covariance3& c) {
  PackedCovariance p;
  std::array<double, 3> s{};
  const int max_level = (1 << kLogSigmaBits) - 1;
  for (int i = 0; i < 3; ++i) {
    s[i] = std::sqrt(c[4 * i]);
    const long level = std::lround((std::log2(s[i]) - kLogSigmaMin) / kLogSigmaStep);
    p.log_sigma[i] = static_cast<std::uint32_t>(std::clamp<long>(level, 0, max_level));
  }
  const std::array<double, 3> r = {c[1] / (s[0] * s[1]), c[2] / (s[0] * s[2]),
                                   c[5] / (s[1] * s[2])};
  // Shrink the correlations towards 0 until the quantised matrix is positive definite
  // ((1 - a) R + a I is positive definite for a correlation matrix R and a > 0).
  for (double shrink = 1.0; shrink > 0.0; shrink -= 0.01) {
    for (int i = 0; i < 3; ++i)
      p.rho[i] = static_cast<std::int32_t>(std::clamp<long>(
          std::lround(r[i] * shrink * kCorrelationScale), -kCorrelationScale, kCorrelationScale));
    if (PositiveDefinite(Unpack(p))) return p;
  }
  p.rho = {0, 0, 0};
  return p;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Heartbeat: header, num_keyframes, acks (robot id, incarnation, object-map version),
// transforms (robot id, T_sender_robot).

std::vector<std::uint8_t> Encode(const msgs::Heartbeat& m, const CodecOptions& o) {
  Encoder e(FleetKind::kHeartbeat, o);
  e.Header(m.header);
  e.Index(m.num_keyframes, "num_keyframes");
  e.Count(m.acks.size(), e.b_.max_acks, "acks");
  for (const auto& a : m.acks) {
    e.Robot(a.robot_id, "ack robot_id");
    e.w.Put(a.incarnation, 32);
    e.w.PutExpGolomb(a.object_map_version, kVersionOrder);
  }
  e.Count(m.transforms.size(), e.b_.max_acks, "transforms");
  for (const auto& t : m.transforms) {
    e.Robot(t.robot_id, "transform robot_id");
    e.Pose(t.T_sender_robot, "transform");
  }
  return e.Finish();
}

DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::Heartbeat* m,
                    const CodecOptions& o, const Bounds& b) {
  Decoder d(FleetKind::kHeartbeat, bytes, o, b);
  msgs::Heartbeat out;
  std::size_t n = 0;
  if (d.Options() && d.Header(&out.header) && d.Index(&out.num_keyframes, "num_keyframes") &&
      d.Count(b.max_acks, &n, "acks")) {
    out.acks.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      msgs::Heartbeat::Ack a;
      std::uint64_t inc = 0;
      if (!d.Robot(&a.robot_id, "ack robot_id") || !d.U(32, &inc, "ack incarnation") ||
          !d.U32(kVersionOrder, &a.object_map_version, "ack object_map_version"))
        break;
      a.incarnation = static_cast<std::uint32_t>(inc);
      out.acks.push_back(a);
    }
    if (out.acks.size() == n && d.Count(b.max_acks, &n, "transforms")) {
      for (std::size_t i = 0; i < n; ++i) {
        msgs::Heartbeat::Transform t;
        if (!d.Robot(&t.robot_id, "transform robot_id") || !d.Pose(&t.T_sender_robot, "transform"))
          break;
        out.transforms.push_back(t);
      }
      d.End();
    }
  }
  const DecodeResult res = d.Result();
  if (res) *m = std::move(out);
  return res;
}

// ---------------------------------------------------------------------------------------
// Object-map update: header, version, base_version, upserts sorted by id (id deltas, centre,
// rectangle-centre offset, sides, 8-bit yaw over [0, pi), num_points), removed ids (deltas),
// after the versions the map's heading (kHeadingBits).

std::vector<std::uint8_t> Encode(const msgs::ObjectMapUpdate& m, const CodecOptions& o) {
  Encoder e(FleetKind::kObjectMap, o);
  e.Header(m.header);
  e.w.PutExpGolomb(m.version, kVersionOrder);
  e.w.PutExpGolomb(m.base_version, kVersionOrder);
  const bool heading = std::isfinite(m.map_heading_rad);
  e.w.Put(heading ? 1u : 0u, 1);
  if (heading) {
    const double turn = 2.0 * std::numbers::pi;
    const double u = m.map_heading_rad - turn * std::floor(m.map_heading_rad / turn);  // [0, 2 pi]
    const auto q = static_cast<std::uint64_t>(std::llround(u / turn * (1 << kHeadingBits))) %
                   (1u << kHeadingBits);
    e.w.Put(q, kHeadingBits);
  }

  std::vector<const msgs::Object*> objs;
  for (const auto& ob : m.upserts) objs.push_back(&ob);
  std::sort(objs.begin(), objs.end(), [](auto* a, auto* c) { return a->id < c->id; });
  e.Count(objs.size(), e.b_.max_objects, "upserts");
  if (!objs.empty()) {
    std::vector<std::uint64_t> ids, cx, cy, rx, ry, len, br, np;
    std::uint32_t prev = 0;
    for (std::size_t i = 0; i < objs.size(); ++i) {
      const msgs::Object& ob = *objs[i];
      if (i > 0 && ob.id == prev) e.Throw(Fmt("object id %u appears twice", ob.id));
      if (ob.landmark != ((ob.id & msgs::kLandmarkIdBit) != 0))
        e.Throw(Fmt("object %u: the landmark flag and the id's landmark bit disagree", ob.id));
      ids.push_back(i == 0 ? ob.id : ob.id - prev - 1);
      prev = ob.id;
      const std::int64_t qx = e.Coordinate(ob.center.x_m, o.position_step_m, "object centre");
      const std::int64_t qy = e.Coordinate(ob.center.y_m, o.position_step_m, "object centre");
      cx.push_back(bits::ZigZag(qx));
      cy.push_back(bits::ZigZag(qy));
      rx.push_back(bits::ZigZag(
          e.Coordinate(ob.rect_center.x_m, o.position_step_m, "object rect_center") - qx));
      ry.push_back(bits::ZigZag(
          e.Coordinate(ob.rect_center.y_m, o.position_step_m, "object rect_center") - qy));
      for (const double side : {ob.length_m, ob.breadth_m})
        if (!(side >= 0.0)) e.Throw(Fmt("object %u side %g is negative", ob.id, side));
      len.push_back(static_cast<std::uint64_t>(
          e.Quantise(ob.length_m, o.size_step_m, e.b_.max_object_side_m, "object length")));
      br.push_back(static_cast<std::uint64_t>(
          e.Quantise(ob.breadth_m, o.size_step_m, e.b_.max_object_side_m, "object breadth")));
      if (ob.num_points < 0) e.Throw(Fmt("object %u num_points is negative", ob.id));
      np.push_back(static_cast<std::uint64_t>(ob.num_points));
    }
    e.Adaptive(ids);
    e.Adaptive(cx);
    e.Adaptive(cy);
    e.Adaptive(rx);
    e.Adaptive(ry);
    e.Adaptive(len);
    e.Adaptive(br);
    for (const auto* ob : objs) {
      if (!std::isfinite(ob->yaw_rad)) e.Throw("object yaw is not finite");
      const auto q = std::llround(HalfTurn(ob->yaw_rad) / std::numbers::pi * (1 << kObjectYawBits));
      e.w.Put(static_cast<std::uint64_t>(q) & ((1u << kObjectYawBits) - 1), kObjectYawBits);
    }
    e.Adaptive(np);
  }

  std::vector<std::uint32_t> removed = m.removed;
  std::sort(removed.begin(), removed.end());
  e.Count(removed.size(), e.b_.max_objects, "removed");
  if (!removed.empty()) {
    std::vector<std::uint64_t> ids;
    for (std::size_t i = 0; i < removed.size(); ++i) {
      if (i > 0 && removed[i] == removed[i - 1])
        e.Throw(Fmt("removed id %u appears twice", removed[i]));
      ids.push_back(i == 0 ? removed[i] : removed[i] - removed[i - 1] - 1);
    }
    e.Adaptive(ids);
  }
  return e.Finish();
}

namespace {

// n values with one per-message order; each at most max_value.
bool ReadAdaptive(Decoder& d, std::size_t n, std::uint64_t max_value, const char* field,
                  std::vector<std::uint64_t>* values) {
  int k = 0;
  if (!d.Order(&k, field)) return false;
  values->clear();
  // Every value takes at least one bit: a count larger than what is left cannot be met, and
  // must not size the vector (n is only checked against Bounds, e.g. 20000 keyframes).
  values->reserve(std::min(n, d.r.remaining_bits()));
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t v = 0;
    if (!d.EG(k, &v, field)) return false;
    if (v > max_value)
      return d.Fail(Fmt("%s %llu exceeds the bound", field, (unsigned long long)v));
    values->push_back(v);
  }
  return true;
}

// Strictly increasing 32-bit ids from their deltas (first absolute, then delta - 1).
bool Ids(Decoder& d, const std::vector<std::uint64_t>& deltas, const char* field,
         std::vector<std::uint32_t>* ids) {
  ids->clear();
  std::uint64_t prev = 0;
  for (std::size_t i = 0; i < deltas.size(); ++i) {
    const std::uint64_t id = i == 0 ? deltas[0] : prev + deltas[i] + 1;
    if (id > kMaxU32) return d.Fail(Fmt("%s id exceeds 32 bits", field));
    ids->push_back(static_cast<std::uint32_t>(id));
    prev = id;
  }
  return true;
}

}  // namespace

DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::ObjectMapUpdate* m,
                    const CodecOptions& o, const Bounds& b) {
  Decoder d(FleetKind::kObjectMap, bytes, o, b);
  msgs::ObjectMapUpdate out;
  std::size_t n = 0;
  const auto run = [&]() {
    if (!d.Options() || !d.Header(&out.header) || !d.U32(kVersionOrder, &out.version, "version") ||
        !d.U32(kVersionOrder, &out.base_version, "base_version"))
      return false;
    std::uint64_t heading = 0, heading_q = 0;
    if (!d.U(1, &heading, "map heading flag")) return false;
    if (heading) {
      if (!d.U(kHeadingBits, &heading_q, "map heading")) return false;
      out.map_heading_rad =
          static_cast<double>(heading_q) * 2.0 * std::numbers::pi / (1 << kHeadingBits) -
          (heading_q >= (1u << (kHeadingBits - 1)) ? 2.0 * std::numbers::pi : 0.0);  // (-pi, pi]
    }
    if (!d.Count(b.max_objects, &n, "upserts")) return false;
    if (n > 0) {
      const std::uint64_t max_coord =
          bits::ZigZag(std::llround(b.max_abs_coordinate_m / o.position_step_m) + 1);
      const std::uint64_t max_side =
          static_cast<std::uint64_t>(std::llround(b.max_object_side_m / o.size_step_m) + 1);
      std::vector<std::uint64_t> ids, cx, cy, rx, ry, len, br, yaw, np;
      if (!ReadAdaptive(d, n, kMaxU32, "upsert ids", &ids) ||
          !ReadAdaptive(d, n, max_coord, "object centre x", &cx) ||
          !ReadAdaptive(d, n, max_coord, "object centre y", &cy) ||
          !ReadAdaptive(d, n, 2 * max_coord, "object rect_center x", &rx) ||
          !ReadAdaptive(d, n, 2 * max_coord, "object rect_center y", &ry) ||
          !ReadAdaptive(d, n, max_side, "object length", &len) ||
          !ReadAdaptive(d, n, max_side, "object breadth", &br))
        return false;
      for (std::size_t i = 0; i < n; ++i) {
        std::uint64_t q = 0;
        if (!d.U(kObjectYawBits, &q, "object yaw")) return false;
        yaw.push_back(q);
      }
      if (!ReadAdaptive(d, n, 0x7fffffff, "object num_points", &np)) return false;
      std::vector<std::uint32_t> id32;
      if (!Ids(d, ids, "upsert", &id32)) return false;
      out.upserts.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        msgs::Object& ob = out.upserts[i];
        ob.id = id32[i];
        const std::int64_t qx = bits::UnZigZag(cx[i]), qy = bits::UnZigZag(cy[i]);
        if (!d.Coordinate(qx, o.position_step_m, &ob.center.x_m, "object centre") ||
            !d.Coordinate(qy, o.position_step_m, &ob.center.y_m, "object centre") ||
            !d.Coordinate(qx + bits::UnZigZag(rx[i]), o.position_step_m, &ob.rect_center.x_m,
                          "object rect_center") ||
            !d.Coordinate(qy + bits::UnZigZag(ry[i]), o.position_step_m, &ob.rect_center.y_m,
                          "object rect_center") ||
            !d.Scaled(static_cast<std::int64_t>(len[i]), o.size_step_m, b.max_object_side_m,
                      &ob.length_m, "object length") ||
            !d.Scaled(static_cast<std::int64_t>(br[i]), o.size_step_m, b.max_object_side_m,
                      &ob.breadth_m, "object breadth"))
          return false;
        ob.yaw_rad = static_cast<double>(yaw[i]) * std::numbers::pi / (1 << kObjectYawBits);
        ob.num_points = static_cast<int>(np[i]);
        ob.landmark = (ob.id & msgs::kLandmarkIdBit) != 0;  // carried in the id
      }
    }
    std::size_t nr = 0;
    if (!d.Count(b.max_objects, &nr, "removed")) return false;
    if (nr > 0) {
      std::vector<std::uint64_t> ids;
      if (!ReadAdaptive(d, nr, kMaxU32, "removed ids", &ids) ||
          !Ids(d, ids, "removed", &out.removed))
        return false;
    }
    return d.End();
  };
  run();
  const DecodeResult res = d.Result();
  if (res) *m = std::move(out);
  return res;
}

// ---------------------------------------------------------------------------------------
// Keyframe poses: header, full bit, count, then per field (with per-message orders): index
// deltas - 1, x/y deltas from the previous entry, yaw deltas, num_points, time deltas.

std::vector<std::uint8_t> Encode(const msgs::KeyframePoses& m, const CodecOptions& o) {
  Encoder e(FleetKind::kKeyframePoses, o);
  e.Header(m.header);
  e.w.PutBit(m.full);
  e.Count(m.poses.size(), e.b_.max_keyframes, "poses");
  if (m.poses.empty()) return e.Finish();
  std::vector<std::uint64_t> idx, xs, ys, yaws, np, ts;
  std::int64_t px = 0, py = 0, pyaw = 0, pt = 0;
  int prev_index = -1;
  for (const auto& p : m.poses) {
    if (p.index < 0 || p.index > e.b_.max_keyframes)
      e.Throw(Fmt("keyframe index %d outside [0, %d]", p.index, e.b_.max_keyframes));
    if (p.index <= prev_index) e.Throw("keyframe indices are not strictly ascending");
    idx.push_back(static_cast<std::uint64_t>(p.index - prev_index - 1));
    prev_index = p.index;
    const std::int64_t qx = e.Coordinate(p.T_map_kf.x_m, o.position_step_m, "keyframe x");
    const std::int64_t qy = e.Coordinate(p.T_map_kf.y_m, o.position_step_m, "keyframe y");
    const std::int64_t qyaw = e.Yaw(p.T_map_kf.yaw_rad, "keyframe yaw");
    const std::int64_t qt = e.Time(p.time_s, "keyframe time");
    xs.push_back(bits::ZigZag(qx - px));
    ys.push_back(bits::ZigZag(qy - py));
    yaws.push_back(bits::ZigZag(qyaw - pyaw));
    ts.push_back(bits::ZigZag(qt - pt));
    px = qx, py = qy, pyaw = qyaw, pt = qt;
    if (p.num_points < 0 || p.num_points > e.b_.max_points)
      e.Throw(Fmt("keyframe num_points %d outside [0, %d]", p.num_points, e.b_.max_points));
    np.push_back(static_cast<std::uint64_t>(p.num_points));
  }
  for (const auto* v : {&idx, &xs, &ys, &yaws, &np, &ts}) e.Adaptive(*v);
  return e.Finish();
}

DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::KeyframePoses* m,
                    const CodecOptions& o, const Bounds& b) {
  Decoder d(FleetKind::kKeyframePoses, bytes, o, b);
  msgs::KeyframePoses out;
  const auto run = [&]() {
    std::size_t n = 0;
    if (!d.Options() || !d.Header(&out.header) || !d.r.GetBit(&out.full) ||
        !d.Count(b.max_keyframes, &n, "poses"))
      return d.r.ok() ? false : d.Truncated("full");
    if (n == 0) return d.End();
    const std::uint64_t max_index = static_cast<std::uint64_t>(std::max(0, b.max_keyframes));
    const std::uint64_t max_coord =
        bits::ZigZag(2 * (std::llround(b.max_abs_coordinate_m / o.position_step_m) + 1));
    const std::uint64_t max_yaw = bits::ZigZag(2 * (std::llround(4.0 / o.yaw_step_rad) + 1));
    const std::uint64_t max_t = bits::ZigZag(2 * (std::llround(b.max_time_s / o.time_step_s) + 1));
    std::vector<std::uint64_t> idx, xs, ys, yaws, np, ts;
    if (!ReadAdaptive(d, n, max_index, "keyframe index", &idx) ||
        !ReadAdaptive(d, n, max_coord, "keyframe x", &xs) ||
        !ReadAdaptive(d, n, max_coord, "keyframe y", &ys) ||
        !ReadAdaptive(d, n, max_yaw, "keyframe yaw", &yaws) ||
        !ReadAdaptive(d, n, static_cast<std::uint64_t>(std::max(0, b.max_points)),
                      "keyframe num_points", &np) ||
        !ReadAdaptive(d, n, max_t, "keyframe time", &ts))
      return false;
    out.poses.resize(n);
    std::int64_t index = -1, qx = 0, qy = 0, qyaw = 0, qt = 0;
    for (std::size_t i = 0; i < n; ++i) {
      auto& p = out.poses[i];
      index += static_cast<std::int64_t>(idx[i]) + 1;
      if (!d.IndexValue(static_cast<std::uint64_t>(index), &p.index, "keyframe index"))
        return false;
      qx += bits::UnZigZag(xs[i]);
      qy += bits::UnZigZag(ys[i]);
      qyaw += bits::UnZigZag(yaws[i]);
      qt += bits::UnZigZag(ts[i]);
      if (!d.Coordinate(qx, o.position_step_m, &p.T_map_kf.x_m, "keyframe x") ||
          !d.Coordinate(qy, o.position_step_m, &p.T_map_kf.y_m, "keyframe y") ||
          !d.Yaw(qyaw, &p.T_map_kf.yaw_rad, "keyframe yaw") ||
          !d.Time(qt, &p.time_s, "keyframe time"))
        return false;
      p.num_points = static_cast<int>(np[i]);
    }
    return d.End();
  };
  run();
  const DecodeResult res = d.Result();
  if (res) *m = std::move(out);
  return res;
}

// ---------------------------------------------------------------------------------------
// Scan request: header, target robot, object-map version, T_requester_target, object ids (in
// the given order, adaptive order), max_scans.

std::vector<std::uint8_t> Encode(const msgs::ScanRequest& m, const CodecOptions& o) {
  Encoder e(FleetKind::kScanRequest, o);
  e.Header(m.header);
  e.Robot(m.target_robot, "target_robot");
  e.w.PutExpGolomb(m.object_map_version, kVersionOrder);
  e.Pose(m.T_requester_target, "T_requester_target");
  e.Count(m.object_ids.size(), e.b_.max_object_ids, "object_ids");
  if (!m.object_ids.empty())
    e.Adaptive(std::vector<std::uint64_t>(m.object_ids.begin(), m.object_ids.end()));
  if (m.max_scans < 0 || m.max_scans > e.b_.max_keyframes)
    e.Throw(Fmt("max_scans %d outside [0, %d]", m.max_scans, e.b_.max_keyframes));
  e.w.PutExpGolomb(static_cast<std::uint64_t>(m.max_scans), kCountOrder);
  return e.Finish();
}

DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::ScanRequest* m,
                    const CodecOptions& o, const Bounds& b) {
  Decoder d(FleetKind::kScanRequest, bytes, o, b);
  msgs::ScanRequest out;
  const auto run = [&]() {
    std::size_t n = 0;
    if (!d.Options() || !d.Header(&out.header) || !d.Robot(&out.target_robot, "target_robot") ||
        !d.U32(kVersionOrder, &out.object_map_version, "object_map_version") ||
        !d.Pose(&out.T_requester_target, "T_requester_target") ||
        !d.Count(b.max_object_ids, &n, "object_ids"))
      return false;
    if (n > 0) {
      std::vector<std::uint64_t> ids;
      if (!ReadAdaptive(d, n, kMaxU32, "object_ids", &ids)) return false;
      out.object_ids.assign(ids.begin(), ids.end());
    }
    std::uint64_t ms = 0;
    if (!d.EG(kCountOrder, &ms, "max_scans")) return false;
    if (ms > static_cast<std::uint64_t>(std::max(0, b.max_keyframes)))
      return d.Fail(
          Fmt("max_scans %llu exceeds the bound %d", (unsigned long long)ms, b.max_keyframes));
    out.max_scans = static_cast<int>(ms);
    return d.End();
  };
  run();
  const DecodeResult res = d.Result();
  if (res) *m = std::move(out);
  return res;
}

// ---------------------------------------------------------------------------------------
// Scan reply: header, requester, keyframe index and time, T_map_kf, point count, point coding
// (2 bits), deflated (1 bit), zero padding to a byte, then the point block (raw or deflated)
// to the end of the payload.

namespace {

struct PointBlockChoice {
  PointCoding coding = PointCoding::kChain;
  bool deflated = false;
  std::vector<std::uint8_t> bytes;
};

PointBlockChoice ChoosePointBlock(const std::vector<GridPoint>& q, bool compress) {
  PointBlockChoice best;
  bool have = false;
  for (int c = 0; c < points::kNumPointCodings; ++c) {
    const auto coding = static_cast<PointCoding>(c);
    std::vector<std::uint8_t> block = points::EncodeBlock(q, coding);
    if (!have || block.size() < best.bytes.size()) best = {coding, false, block}, have = true;
    if (compress && !block.empty()) {
      std::vector<std::uint8_t> z = points::Deflate(block);
      if (!z.empty() && z.size() < best.bytes.size()) best = {coding, true, std::move(z)};
    }
  }
  return best;
}

}  // namespace

namespace {

std::vector<std::uint8_t> EncodeScanReply(const msgs::ScanReply& m, const CodecOptions& o,
                                          int forced_coding, bool forced_deflate) {
  Encoder e(FleetKind::kScanReply, o);
  e.Header(m.header);
  e.Robot(m.requester_robot, "requester_robot");
  e.Index(m.keyframe, "keyframe");
  e.w.PutSignedExpGolomb(e.Time(m.keyframe_time_s, "keyframe_time"), kTimeOrder);
  e.Pose(m.T_map_kf, "T_map_kf");
  e.Count(m.points_kf.size(), e.b_.max_points, "points");
  std::vector<GridPoint> q;
  q.reserve(m.points_kf.size());
  for (const auto& p : m.points_kf)
    q.push_back({e.Coordinate(p.x_m, o.point_step_m, "point x"),
                 e.Coordinate(p.y_m, o.point_step_m, "point y")});
  PointBlockChoice block;
  if (forced_coding < 0) {
    block = ChoosePointBlock(q, o.compress_points);
  } else {
    block.coding = static_cast<PointCoding>(forced_coding);
    block.bytes = points::EncodeBlock(q, block.coding);
    if (forced_deflate) {
      block.bytes = points::Deflate(block.bytes);
      block.deflated = true;
    }
  }
  e.w.Put(static_cast<std::uint64_t>(block.coding), 2);
  e.w.PutBit(block.deflated);
  e.w.PutBytes(block.bytes);
  return e.Finish();
}

}  // namespace

std::vector<std::uint8_t> Encode(const msgs::ScanReply& m, const CodecOptions& o) {
  return EncodeScanReply(m, o, -1, false);
}

namespace points {
std::vector<std::uint8_t> EncodeScanReplyWith(const msgs::ScanReply& m, const CodecOptions& o,
                                              PointCoding coding, bool deflate) {
  return EncodeScanReply(m, o, static_cast<int>(coding), deflate);
}
}  // namespace points

DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::ScanReply* m,
                    const CodecOptions& o, const Bounds& b) {
  Decoder d(FleetKind::kScanReply, bytes, o, b);
  msgs::ScanReply out;
  const auto run = [&]() {
    std::int64_t qt = 0;
    std::size_t n = 0;
    std::uint64_t coding = 0;
    bool deflated = false;
    if (!d.Options() || !d.Header(&out.header) ||
        !d.Robot(&out.requester_robot, "requester_robot") || !d.Index(&out.keyframe, "keyframe") ||
        !d.SEG(kTimeOrder, &qt, "keyframe_time") ||
        !d.Time(qt, &out.keyframe_time_s, "keyframe_time") || !d.Pose(&out.T_map_kf, "T_map_kf") ||
        !d.Count(b.max_points, &n, "points") || !d.U(2, &coding, "point coding") ||
        !d.r.GetBit(&deflated) || !d.r.AlignToByte())
      return d.r.ok() ? false : d.Truncated("point coding");
    const std::size_t start = d.r.position_bits() / 8;
    std::vector<std::uint8_t> block(bytes.begin() + static_cast<std::ptrdiff_t>(start),
                                    bytes.end());
    if (deflated) {
      // No coding takes more than 2 x 64 bits per point (plus a small block header).
      std::vector<std::uint8_t> raw;
      if (!points::Inflate(block, 16 * n + 64, &raw))
        return d.Fail("points: bad or oversized deflate stream");
      block = std::move(raw);
    }
    const std::int64_t max_abs = std::llround(b.max_abs_coordinate_m / o.point_step_m) + 1;
    std::vector<GridPoint> q;
    const std::string err = points::DecodeBlock(block, static_cast<PointCoding>(coding),
                                                static_cast<int>(n), max_abs, &q);
    if (!err.empty())
      return d.Fail("points (" +
                    std::string(points::PointCodingName(static_cast<PointCoding>(coding))) +
                    "): " + err);
    out.points_kf.reserve(q.size());
    for (const auto& p : q) {
      msgs::Point2 pt;
      if (!d.Coordinate(p.x, o.point_step_m, &pt.x_m, "point x") ||
          !d.Coordinate(p.y, o.point_step_m, &pt.y_m, "point y"))
        return false;
      out.points_kf.push_back(pt);
    }
    return true;
  };
  run();
  const DecodeResult res = d.Result();
  if (res) *m = std::move(out);
  return res;
}

// ---------------------------------------------------------------------------------------
// Loop closures: header, target robot, count, then per loop: id (first absolute, then zigzag
// delta), robots and keyframes, pose, covariance (3 x 10-bit log2 sigma, 3 x 10-bit
// correlation), overlap (8 bits), flags.

std::vector<std::uint8_t> Encode(const msgs::LoopClosureMessage& m, const CodecOptions& o) {
  Encoder e(FleetKind::kLoopClosures, o);
  e.Header(m.header);
  e.Robot(m.target_robot, "target_robot");
  e.Count(m.loops.size(), e.b_.max_loops, "loops");
  std::uint64_t prev_id = 0;
  for (const auto& l : m.loops) {
    e.w.PutSignedExpGolomb(static_cast<std::int64_t>(l.id - prev_id), 4);
    prev_id = l.id;
    e.Robot(l.own_robot, "loop own_robot");
    e.Index(l.own_keyframe, "loop own_keyframe");
    e.Robot(l.teammate_robot, "loop teammate_robot");
    e.Index(l.teammate_keyframe, "loop teammate_keyframe");
    e.Pose(l.T_ownkf_teammatekf, "loop T_ownkf_teammatekf");
    auto c = l.covariance;
    for (const double v : c)
      if (!std::isfinite(v)) e.Throw("loop covariance is not finite");
    // Rounding leaves covariances from a solver a few ulps off symmetric: those are averaged;
    // a real asymmetry is an error.
    const double scale = std::abs(c[0]) + std::abs(c[4]) + std::abs(c[8]);
    for (const auto& [i, j] : {std::pair{1, 3}, std::pair{2, 6}, std::pair{5, 7}}) {
      if (std::abs(c[i] - c[j]) > 1e-9 * scale)
        e.Throw(Fmt("loop %llu covariance is not symmetric", (unsigned long long)l.id));
      c[i] = c[j] = 0.5 * (c[i] + c[j]);
    }
    if (!PositiveDefinite(c))
      e.Throw(Fmt("loop %llu covariance is not positive definite", (unsigned long long)l.id));
    const PackedCovariance p = Pack(c);
    for (const auto s : p.log_sigma) e.w.Put(s, kLogSigmaBits);
    for (const auto r : p.rho)
      e.w.Put(static_cast<std::uint64_t>(r + kCorrelationScale), kCorrelationBits);
    if (!(l.overlap >= 0.0 && l.overlap <= 1.0))
      e.Throw(Fmt("loop overlap %g outside [0, 1]", l.overlap));
    e.w.Put(static_cast<std::uint64_t>(std::lround(l.overlap * ((1 << kOverlapBits) - 1))),
            kOverlapBits);
    e.w.PutExpGolomb(l.flags, 0);
  }
  return e.Finish();
}

DecodeResult Decode(const std::vector<std::uint8_t>& bytes, msgs::LoopClosureMessage* m,
                    const CodecOptions& o, const Bounds& b) {
  Decoder d(FleetKind::kLoopClosures, bytes, o, b);
  msgs::LoopClosureMessage out;
  const auto run = [&]() {
    std::size_t n = 0;
    if (!d.Options() || !d.Header(&out.header) || !d.Robot(&out.target_robot, "target_robot") ||
        !d.Count(b.max_loops, &n, "loops"))
      return false;
    out.loops.reserve(n);
    std::uint64_t prev_id = 0;
    for (std::size_t i = 0; i < n; ++i) {
      msgs::InterRobotLoop l;
      std::int64_t did = 0;
      if (!d.SEG(4, &did, "loop id")) return false;
      l.id = prev_id + static_cast<std::uint64_t>(did);
      prev_id = l.id;
      if (!d.Robot(&l.own_robot, "loop own_robot") ||
          !d.Index(&l.own_keyframe, "loop own_keyframe") ||
          !d.Robot(&l.teammate_robot, "loop teammate_robot") ||
          !d.Index(&l.teammate_keyframe, "loop teammate_keyframe") ||
          !d.Pose(&l.T_ownkf_teammatekf, "loop T_ownkf_teammatekf"))
        return false;
      PackedCovariance p;
      for (auto& s : p.log_sigma) {
        std::uint64_t v = 0;
        if (!d.U(kLogSigmaBits, &v, "loop covariance sigma")) return false;
        s = static_cast<std::uint32_t>(v);
      }
      for (auto& r : p.rho) {
        std::uint64_t v = 0;
        if (!d.U(kCorrelationBits, &v, "loop covariance correlation")) return false;
        r = static_cast<std::int32_t>(v) - kCorrelationScale;
        if (r < -kCorrelationScale || r > kCorrelationScale)
          return d.Fail("loop covariance correlation outside [-1, 1]");
      }
      l.covariance = Unpack(p);
      for (const double v : l.covariance)
        if (!std::isfinite(v)) return d.Fail("loop covariance is not finite");
      if (!PositiveDefinite(l.covariance))
        return d.Fail("loop covariance is not positive definite");
      std::uint64_t ov = 0, flags = 0;
      if (!d.U(kOverlapBits, &ov, "loop overlap") || !d.EG(0, &flags, "loop flags")) return false;
      if (ov > (1u << kOverlapBits) - 1) return d.Fail("loop overlap outside [0, 1]");
      l.overlap = static_cast<double>(ov) / ((1 << kOverlapBits) - 1);
      if (flags > kMaxU32) return d.Fail("loop flags exceed 32 bits");
      l.flags = static_cast<std::uint32_t>(flags);
      out.loops.push_back(l);
    }
    return d.End();
  };
  run();
  const DecodeResult res = d.Result();
  if (res) *m = std::move(out);
  return res;
}

}  // namespace draco::fleet
