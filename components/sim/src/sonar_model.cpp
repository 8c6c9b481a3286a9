#include "draco/sim/sonar_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "draco/sim/random.hpp"

namespace draco::sim {

namespace {

constexpr int kTableBits = 16;
constexpr std::size_t kTableSize = std::size_t{1} << kTableBits;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct BeamInterval {
  double s_in;
  double s_out;
  Vec2 normal;
  int primitive;
};

// Per-thread work buffers, reused across pings.
struct Scratch {
  std::vector<std::vector<BeamInterval>> per_beam;
  std::vector<float> energy;   // objects (sparse), blurred by scattering the kernel
  std::vector<float> blurred;  // objects after blur
  std::vector<float> bed;      // seabed (dense, smooth) and streaks
  std::vector<float> row_normal;
  std::vector<std::uint8_t> row_used;  // rows with object energy
  std::vector<double> cos_b;
  std::vector<double> sin_b;
};

Scratch& ThreadScratch() {
  thread_local Scratch scratch;
  return scratch;
}

// Smooth value noise in [-1, 1] on a grid of cell size 1 (for seabed patches).
inline double ValueNoise(double x, double y, std::uint64_t salt) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx);
  const auto iy = static_cast<std::int64_t>(fy);
  // Mix64 inlined (the splitmix64 finaliser), each corner hashed once.
  auto h = [salt](std::int64_t a, std::int64_t b) {
    std::uint64_t k = (static_cast<std::uint64_t>(a) * 0x9E3779B1ULL ^
                       (static_cast<std::uint64_t>(b) << 32) ^ salt) +
                      0x9e3779b97f4a7c15ULL;
    k = (k ^ (k >> 30)) * 0xbf58476d1ce4e5b9ULL;
    k = (k ^ (k >> 27)) * 0x94d049bb133111ebULL;
    k ^= k >> 31;
    return static_cast<double>(k >> 11) * 0x1.0p-53 * 2.0 - 1.0;
  };
  double tx = x - fx;
  double ty = y - fy;
  tx = tx * tx * (3.0 - 2.0 * tx);
  ty = ty * ty * (3.0 - 2.0 * ty);
  const double h00 = h(ix, iy);
  const double h10 = h(ix + 1, iy);
  const double h01 = h(ix, iy + 1);
  const double h11 = h(ix + 1, iy + 1);
  const double v0 = h00 + tx * (h10 - h00);
  const double v1 = h01 + tx * (h11 - h01);
  return v0 + ty * (v1 - v0);
}

std::vector<float> GaussianKernel(double sigma) {
  if (sigma <= 1e-3) return {1.0f};
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  std::vector<float> k(2 * radius + 1);
  double sum = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    const double v = std::exp(-0.5 * i * i / (sigma * sigma));
    k[i + radius] = static_cast<float>(v);
    sum += v;
  }
  for (auto& v : k) v = static_cast<float>(v / sum);
  return k;
}

}  // namespace

SonarModel::SonarModel(const World& world, const SonarOptions& options)
    : world_(world), options_(options) {
  const int nb = options_.num_beams;
  const double k = options_.bearing_nonuniformity;
  const double half = 0.5 * options_.horizontal_aperture_rad;
  bearings_rad_.resize(nb);
  for (int i = 0; i < nb; ++i) {
    const double u = nb == 1 ? 0.0 : -1.0 + 2.0 * i / (nb - 1);
    bearings_rad_[i] = static_cast<float>(half * (u + k * u * u * u) / (1.0 + k));
  }
  Rng rng(0x50a4e5eedULL);
  speckle_table_.resize(kTableSize);
  exp_table_.resize(kTableSize);
  const double looks = std::max(0.2, options_.speckle_looks);
  for (std::size_t i = 0; i < kTableSize; ++i) {
    speckle_table_[i] = static_cast<float>(rng.Gamma(looks) / looks);
    exp_table_[i] = static_cast<float>(rng.Exponential());
  }
  // u8 = 255 * sqrt(intensity), intensity in [0, 1] quantised to 2^16 steps.
  amplitude_lut_.resize(kTableSize);
  for (std::size_t i = 0; i < kTableSize; ++i) {
    const double intensity = (static_cast<double>(i) + 0.5) / (kTableSize - 1);
    amplitude_lut_[i] =
        static_cast<std::uint8_t>(std::min(255.0, std::lround(255.0 * std::sqrt(intensity)) * 1.0));
  }
  amplitude_lut_[0] = 0;
}

msgs::SonarPing SonarModel::Render(const SonarPose& pose, double time_s, std::uint32_t ping_id,
                                   std::uint64_t seed, SonarTruth* truth) const {
  const SonarOptions& o = options_;
  const int nb = o.num_beams;
  const int nr = o.num_ranges;
  const double dr = o.range_max_m / nr;
  const double rmax = o.range_max_m;
  const std::size_t cells = static_cast<std::size_t>(nb) * nr;
  Rng rng(seed);

  Scratch& sc = ThreadScratch();
  sc.per_beam.resize(nb);
  for (auto& v : sc.per_beam) v.clear();
  sc.energy.assign(cells, 0.0f);
  sc.bed.assign(cells, 0.0f);
  sc.row_normal.assign(nr, 0.0f);
  sc.row_used.assign(nr, 0);
  sc.cos_b.resize(nb);
  sc.sin_b.resize(nb);
  for (int b = 0; b < nb; ++b) {
    const double a = pose.yaw_rad + bearings_rad_[b];
    sc.cos_b[b] = std::cos(a);
    sc.sin_b[b] = std::sin(a);
  }
  std::vector<float> object_energy;
  std::vector<float> seabed_energy;
  if (truth != nullptr) {
    object_energy.assign(cells, 0.0f);
    seabed_energy.assign(cells, 0.0f);
  }

  // 1. Broad phase: each primitive within range covers an interval of bearings; only the
  //    beams inside it are intersected (2D, analytic).
  const Vec2 origin{pose.x_m, pose.y_m};
  const double lowest_elev = -pose.tilt_rad - 0.5 * o.vertical_aperture_rad;
  const double highest_elev = -pose.tilt_rad + 0.5 * o.vertical_aperture_rad;
  const float bearing_lo = bearings_rad_.front();
  const float bearing_hi = bearings_rad_.back();
  for (std::size_t pi = 0; pi < world_.primitives.size(); ++pi) {
    const Primitive& p = world_.primitives[pi];
    const Vec2 rel = p.center_m - origin;
    const double d = Norm(rel);
    if (d - p.radius_m > rmax) continue;
    // Vertical culling: the fan spans heights z0 + s tan(elev) for s <= d + radius.
    const double reach = d + p.radius_m;
    const double fan_low = pose.z_m + reach * std::tan(std::min(lowest_elev, 0.0));
    const double fan_high = pose.z_m + reach * std::tan(std::max(highest_elev, 0.0));
    if (p.z_max_m < fan_low || p.z_min_m > fan_high) continue;
    int b_begin = 0;
    int b_end = nb;
    if (d > p.radius_m) {
      const double alpha = WrapAngle(std::atan2(rel.y, rel.x) - pose.yaw_rad);
      const double half = std::asin(std::min(1.0, p.radius_m / d));
      const double lo = alpha - half;
      const double hi = alpha + half;
      if (hi < bearing_lo || lo > bearing_hi) continue;
      b_begin = static_cast<int>(
          std::lower_bound(bearings_rad_.begin(), bearings_rad_.end(), static_cast<float>(lo)) -
          bearings_rad_.begin());
      b_end = static_cast<int>(
          std::upper_bound(bearings_rad_.begin(), bearings_rad_.end(), static_cast<float>(hi)) -
          bearings_rad_.begin());
    }
    for (int b = b_begin; b < b_end; ++b) {
      const Vec2 dir{sc.cos_b[b], sc.sin_b[b]};
      RayInterval iv;
      bool hit = false;
      switch (p.kind) {
        case ShapeKind::kCircle:
          hit = IntersectRayCircle(origin, dir, p.center_m, p.radius_m, &iv);
          break;
        case ShapeKind::kConvexPolygon:
          hit = IntersectRayConvexPolygon(origin, dir, p.vertices_m, &iv);
          break;
        case ShapeKind::kSegment:
          hit = IntersectRaySegment(origin, dir, p.vertices_m[0], p.vertices_m[1], &iv);
          break;
      }
      if (hit && iv.s_in < rmax) {
        sc.per_beam[b].push_back({iv.s_in, iv.s_out, iv.normal_in, static_cast<int>(pi)});
      }
    }
  }

  // 2. Elevation rays per beam: first hit among prisms, the seabed and the surface.
  const int n_el = std::max(1, o.elevation_rays);
  const double slice = o.vertical_aperture_rad / n_el;
  const double elev_top = highest_elev;
  const double elev_center = -pose.tilt_rad;
  const double absorb = -2.0 * o.absorption_db_per_m / 10.0 * std::log(10.0);  // per metre
  const Seabed& bed = world_.seabed;
  const double bed_z0 = bed.ZAt(pose.x_m, pose.y_m);
  const double bed_norm = std::sqrt(1.0 + bed.slope_x * bed.slope_x + bed.slope_y * bed.slope_y);
  const double object_scale = o.object_gain / n_el;
  const double seabed_scale = o.seabed_gain;

  auto deposit = [&](int beam, double range_m, double e, bool object) {
    const double f = range_m / dr - 1.0;
    if (f < 0.0 || f >= nr - 1) return;
    const int i0 = static_cast<int>(f);
    const double w1 = f - i0;
    const std::size_t c0 = static_cast<std::size_t>(i0) * nb + beam;
    auto& layer = object ? sc.energy : sc.bed;
    layer[c0] += static_cast<float>(e * (1.0 - w1));
    layer[c0 + nb] += static_cast<float>(e * w1);
    if (object) {
      sc.row_used[i0] = 1;
      sc.row_used[i0 + 1] = 1;
    }
    if (truth != nullptr) {
      auto& t = object ? object_energy : seabed_energy;
      t[c0] += static_cast<float>(e * (1.0 - w1));
      t[c0 + nb] += static_cast<float>(e * w1);
    }
  };

  // Elevation samples: kSubSlices jittered positions per slice, tabulated once per ping.
  constexpr int kSubSlices = 16;
  struct Elevation {
    double elev, t, c, s, pattern;
  };
  std::vector<Elevation> elevations(static_cast<std::size_t>(n_el) * kSubSlices);
  for (int k = 0; k < n_el; ++k) {
    for (int j = 0; j < kSubSlices; ++j) {
      const double elev = elev_top - (k + (j + 0.5) / kSubSlices) * slice;
      const double e_rel = (elev - elev_center) / (0.5 * o.vertical_aperture_rad);
      elevations[static_cast<std::size_t>(k) * kSubSlices + j] = {
          elev, std::tan(elev), std::cos(elev), std::sin(elev),
          std::max(0.0, 1.0 - 0.6 * e_rel * e_rel)};
    }
  }
  std::vector<double> boundary_t(n_el + 1);
  std::vector<double> boundary_c(n_el + 1);
  for (int k = 0; k <= n_el; ++k) {
    boundary_t[k] = std::tan(elev_top - k * slice);
    boundary_c[k] = std::cos(elev_top - k * slice);
  }
  // Slant range where elevation boundary k meets the seabed (rising g per metre).
  auto seabed_range = [&](int k, double g) {
    const double t = boundary_t[k];
    if (t >= g) return kInf;
    return (bed_z0 - pose.z_m) / (t - g) / boundary_c[k];
  };

  for (int b = 0; b < nb; ++b) {
    auto& ivs = sc.per_beam[b];
    std::sort(ivs.begin(), ivs.end(),
              [](const BeamInterval& a, const BeamInterval& c) { return a.s_in < c.s_in; });
    const Vec2 dir{sc.cos_b[b], sc.sin_b[b]};
    const double g = bed.slope_x * dir.x + bed.slope_y * dir.y;  // seabed rise per metre
    std::uint64_t jitter_bits = 0;
    for (int k = 0; k < n_el; ++k) {
      if (k % 16 == 0) jitter_bits = rng.NextU64();
      const Elevation& ev = elevations[static_cast<std::size_t>(k) * kSubSlices +
                                       ((jitter_bits >> (4 * (k % 16))) & (kSubSlices - 1))];
      const double t = ev.t;
      const double c = ev.c;
      const double pattern = ev.pattern;

      enum { kNone, kBed, kSurface, kObject } kind = kNone;
      double best = kInf;
      double cos_inc = 0.0;
      int prim = -1;
      if (t < g) {
        best = (bed_z0 - pose.z_m) / (t - g);
        kind = kBed;
      }
      if (t > 0.0) {
        const double s_surface = -pose.z_m / t;
        if (s_surface < best) {
          best = s_surface;
          kind = kSurface;
        }
      }
      for (const BeamInterval& iv : ivs) {
        if (iv.s_in >= best) break;
        const Primitive& p = world_.primitives[iv.primitive];
        const double s0 = std::max(iv.s_in, 0.0);
        const double z = pose.z_m + s0 * t;
        if (z >= p.z_min_m && z <= p.z_max_m) {
          if (iv.s_in >= 0.0) {  // a sensor inside a footprint sees out of it
            best = s0;
            kind = kObject;
            prim = iv.primitive;
            cos_inc = c * std::abs(Dot(dir, iv.normal));
          }
        } else if (z > p.z_max_m && t < 0.0) {
          const double s_top = (p.z_max_m - pose.z_m) / t;
          if (s_top <= iv.s_out && s_top < best) {
            best = s_top;
            kind = kObject;
            prim = iv.primitive;
            cos_inc = std::abs(ev.s);
          }
        } else if (z < p.z_min_m && t > 0.0) {
          const double s_bottom = (p.z_min_m - pose.z_m) / t;
          if (s_bottom <= iv.s_out && s_bottom < best) {
            best = s_bottom;
            kind = kObject;
            prim = iv.primitive;
            cos_inc = ev.s;
          }
        }
      }
      if (kind == kObject) {
        const double r = best / c + o.range_jitter_sigma_m * rng.Normal();
        if (r >= rmax) continue;
        const double refl = world_.materials[world_.primitives[prim].material].reflectivity;
        const double e = object_scale * refl * cos_inc * cos_inc * pattern * std::exp(absorb * r);
        deposit(b, r, e, true);
        if (cos_inc > 0.95) {
          const int row = static_cast<int>(r / dr - 1.0);
          if (row >= 0 && row < nr) sc.row_normal[row] += 1.0f / n_el;
        }
        if (o.ghost_amplitude > 0.0) {
          // Surface multipath: sonar -> target -> surface -> sonar; mirror image at -z.
          const double zp = pose.z_m + best * t;
          const double mirrored = std::hypot(best, zp + pose.z_m);
          const double r_ghost = 0.5 * (r + mirrored);
          deposit(b, r_ghost, o.ghost_amplitude * e, true);
        }
      } else if (kind == kBed) {
        const double r = best / c;
        // The slice's footprint may start inside the range even when this ray lands beyond.
        if (std::min(r, seabed_range(k + 1, g)) >= rmax) continue;
        const double px = pose.x_m + best * dir.x;
        const double py = pose.y_m + best * dir.y;
        // Grazing angle between the ray and the seabed plane.
        const double sin_graze =
            std::abs(-bed.slope_x * c * dir.x - bed.slope_y * c * dir.y + ev.s) / bed_norm;
        const double scale = bed.texture_scale_m;
        const double texture =
            1.0 +
            bed.texture_contrast * (0.7 * ValueNoise(px / scale, py / scale, 17) +
                                    0.3 * ValueNoise(px / (0.3 * scale), py / (0.3 * scale), 29));
        // Backscatter grows with the grazing angle; sqrt rather than Lambert's sin^2 because
        // the device's time-varied gain flattens the seabed's range profile.
        const double e = seabed_scale * bed.backscatter * texture * std::sqrt(sin_graze) * pattern *
                         std::exp(absorb * r);
        // Splat over this slice's range footprint so the seabed is continuous in range.
        const double r_near = std::min(seabed_range(k + 1, g), rmax);
        const double r_far = std::min(seabed_range(k, g), rmax);
        const double f0 = std::max(0.0, r_near / dr - 1.0);
        const double f1 = std::min(static_cast<double>(nr - 1), r_far / dr - 1.0);
        if (f1 <= f0) {
          if (r < rmax) deposit(b, r, e, false);
          continue;
        }
        // Long footprints (the upper, near-grazing slices) are re-evaluated every kSegment
        // bins at their own range (flat-seabed geometry), so texture, grazing angle, beam
        // pattern and absorption vary along them instead of making radial stripes.
        constexpr int kSegment = 8;
        const bool long_footprint = f1 - f0 > kSegment;
        const double height = pose.z_m - bed_z0;
        double e_segment = e;
        int segment = -1;
        for (int i = static_cast<int>(f0); i <= static_cast<int>(f1) && i < nr; ++i) {
          const double cover = std::min(f1, i + 1.0) - std::max(f0, static_cast<double>(i));
          if (cover <= 0.0) continue;
          if (long_footprint && i / kSegment != segment) {
            segment = i / kSegment;
            const double rm = (segment * kSegment + 0.5 * kSegment + 1.0) * dr;
            const double sin_el = std::min(1.0, height / rm);
            const double sm = rm * std::sqrt(1.0 - sin_el * sin_el);
            const double qx = pose.x_m + sm * dir.x;
            const double qy = pose.y_m + sm * dir.y;
            const double tex =
                1.0 + bed.texture_contrast *
                          (0.7 * ValueNoise(qx / scale, qy / scale, 17) +
                           0.3 * ValueNoise(qx / (0.3 * scale), qy / (0.3 * scale), 29));
            const double er = std::clamp(
                (-std::asin(sin_el) - elev_center) / (0.5 * o.vertical_aperture_rad), -1.0, 1.0);
            e_segment = seabed_scale * bed.backscatter * tex * std::sqrt(sin_el) *
                        (1.0 - 0.6 * er * er) * std::exp(absorb * rm);
          }
          const std::size_t cell = static_cast<std::size_t>(i) * nb + b;
          sc.bed[cell] += static_cast<float>(e_segment * cover);
          if (truth != nullptr) seabed_energy[cell] += static_cast<float>(e_segment * cover);
        }
      }
    }
  }

  // 3. Streaks: a large surface facing the sonar rings across the whole row.
  for (int i = 0; i < nr; ++i) {
    if (sc.row_normal[i] <= o.streak_fraction * nb) continue;
    float row_max = 0.0f;
    const float* obj = &sc.energy[static_cast<std::size_t>(i) * nb];
    for (int b = 0; b < nb; ++b) row_max = std::max(row_max, obj[b]);
    const float add = static_cast<float>(o.streak_level) * row_max;
    float* row = &sc.bed[static_cast<std::size_t>(i) * nb];
    for (int b = 0; b < nb; ++b) row[b] += add;
  }

  // 4. Beam pattern and range blur. Object returns are sparse: scatter a separable Gaussian
  //    from each lit cell. The seabed is already smooth; a 3-tap filter across beams softens
  //    its shadow edges.
  const double beam_spacing = o.horizontal_aperture_rad / std::max(1, nb - 1);
  const auto kb = GaussianKernel(o.beam_blur_fwhm_rad / 2.3548 / beam_spacing);
  const auto kr = GaussianKernel(o.range_blur_sigma_bins);
  const int rb = static_cast<int>(kb.size() / 2);
  const int rr = static_cast<int>(kr.size() / 2);
  sc.blurred.assign(cells, 0.0f);
  for (int i = 0; i < nr; ++i) {
    if (!sc.row_used[i]) continue;
    const float* src = &sc.energy[static_cast<std::size_t>(i) * nb];
    const int ilo = std::max(0, i - rr);
    const int ihi = std::min(nr - 1, i + rr);
    for (int b = 0; b < nb; ++b) {
      const float v = src[b];
      if (v == 0.0f) continue;
      const int lo = std::max(0, b - rb);
      const int hi = std::min(nb - 1, b + rb);
      for (int j = ilo; j <= ihi; ++j) {
        const float vr = v * kr[j - i + rr];
        float* dst = &sc.blurred[static_cast<std::size_t>(j) * nb];
        for (int c = lo; c <= hi; ++c) dst[c] += vr * kb[c - b + rb];
      }
    }
  }
  for (int i = 0; i < nr; ++i) {
    float* row = &sc.bed[static_cast<std::size_t>(i) * nb];
    float prev = row[0];
    for (int b = 1; b + 1 < nb; ++b) {
      const float cur = row[b];
      row[b] = 0.25f * prev + 0.5f * cur + 0.25f * row[b + 1];
      prev = cur;
    }
  }

  // 5. Speckle, noise floor, near-field clutter, 8-bit output.
  msgs::SonarPing ping;
  ping.time_s = time_s;
  ping.ping_id = ping_id;
  ping.num_ranges = nr;
  ping.num_beams = nb;
  ping.range_resolution_m = dr;
  ping.bearings_rad = bearings_rad_;
  ping.vertical_aperture_rad = o.vertical_aperture_rad;
  ping.intensity.resize(cells);
  const float gain = static_cast<float>(o.gain);
  const float* speckle = speckle_table_.data();
  const float* expo = exp_table_.data();
  const std::uint8_t* to_u8 = amplitude_lut_.data();
  const float lut_scale = static_cast<float>(amplitude_lut_.size() - 1);
  constexpr double kRayleighMeanToSigma = 0.7978845608;  // sqrt(2 / pi)
  // Per-cell variates: table indices from a SplitMix64 stream seeded by the ping's mt19937_64
  // (fast, and like everything here independent of the standard library's distributions).
  std::uint64_t cell_state = rng.NextU64();
  for (int i = 0; i < nr; ++i) {
    const double r = (i + 1) * dr;
    const double s_range = o.noise_sigma * (r / rmax) * (r / rmax);
    const double s_near =
        o.near_field_amplitude * std::exp(-r / o.near_field_length_m) * kRayleighMeanToSigma;
    // Rayleigh amplitude with scale s has intensity 2 s^2 * Exponential(1).
    const float noise_mean = static_cast<float>(
        2.0 * (o.noise_floor_sigma * o.noise_floor_sigma + s_range * s_range + s_near * s_near));
    const float* eo = &sc.blurred[static_cast<std::size_t>(i) * nb];
    const float* eb = &sc.bed[static_cast<std::size_t>(i) * nb];
    std::uint8_t* out = &ping.intensity[static_cast<std::size_t>(i) * nb];
    for (int b = 0; b < nb; b += 2) {
      cell_state += 0x9e3779b97f4a7c15ULL;
      std::uint64_t w = cell_state;
      w = (w ^ (w >> 30)) * 0xbf58476d1ce4e5b9ULL;
      w = (w ^ (w >> 27)) * 0x94d049bb133111ebULL;
      w ^= w >> 31;
      for (int h = 0; h < 2 && b + h < nb; ++h) {
        const std::uint64_t bits = w >> (32 * h);
        const float sp = speckle[bits & (kTableSize - 1)];
        const float ex = expo[(bits >> kTableBits) & (kTableSize - 1)];
        const float intensity = gain * (eo[b + h] + eb[b + h]) * sp + noise_mean * ex;
        const float x = std::min(intensity, 1.0f) * lut_scale;
        out[b + h] = to_u8[static_cast<std::uint32_t>(x)];
      }
    }
  }

  if (truth != nullptr) {
    truth->object_energy = std::move(object_energy);
    truth->seabed_energy = std::move(seabed_energy);
    // Cells an object can light after blur: dilate the hit cells by the kernels.
    truth->object_mask.assign(cells, 0);
    for (int i = 0; i < nr; ++i) {
      for (int b = 0; b < nb; ++b) {
        if (truth->object_energy[static_cast<std::size_t>(i) * nb + b] <= 0.0f) continue;
        for (int di = std::max(0, i - rr - 1); di <= std::min(nr - 1, i + rr + 1); ++di) {
          for (int db = std::max(0, b - rb); db <= std::min(nb - 1, b + rb); ++db) {
            truth->object_mask[static_cast<std::size_t>(di) * nb + db] = 1;
          }
        }
      }
    }
  }
  return ping;
}

}  // namespace draco::sim
