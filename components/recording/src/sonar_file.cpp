// sonar.drs: little-endian, streaming records, each CRC-checked. Layout in
// docs/recording-format.md.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <new>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <utility>

#include <zlib.h>
#include <zstd.h>

#include "huffman_deflate.hpp"
#include "internal.hpp"

namespace draco::recording::internal {
namespace {

// ---- little-endian encoding -------------------------------------------------------------

void PutU8(std::vector<std::uint8_t>& out, std::uint8_t v) { out.push_back(v); }

void PutU16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}

void PutU32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void PutU64(std::vector<std::uint8_t>& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void PutF64(std::vector<std::uint8_t>& out, double v) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof(bits));
  PutU64(out, bits);
}

void PutF32(std::vector<std::uint8_t>& out, float v) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &v, sizeof(bits));
  PutU32(out, bits);
}

void SetU32(std::vector<std::uint8_t>& out, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

std::uint16_t GetU16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}

std::uint32_t GetU32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

std::uint64_t GetU64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

double GetF64(const std::uint8_t* p) {
  const std::uint64_t bits = GetU64(p);
  double v = 0.0;
  std::memcpy(&v, &bits, sizeof(v));
  return v;
}

float GetF32(const std::uint8_t* p) {
  const std::uint32_t bits = GetU32(p);
  float v = 0.0f;
  std::memcpy(&v, &bits, sizeof(v));
  return v;
}

// Appends the record header with a placeholder length; FinishRecord fills it and adds the CRC.
std::size_t BeginRecord(std::vector<std::uint8_t>& out, std::uint16_t type) {
  out.insert(out.end(), kRecordMagic, kRecordMagic + 4);
  const std::size_t start = out.size();
  PutU16(out, type);
  PutU16(out, 0);  // record flags, reserved
  PutU32(out, 0);  // payload length, filled in below
  return start;
}

void FinishRecord(std::vector<std::uint8_t>& out, std::size_t start) {
  const std::size_t payload = out.size() - start - 8;
  if (payload > kMaxPayloadBytes) throw std::invalid_argument("sonar record larger than 256 MiB");
  SetU32(out, start + 4, static_cast<std::uint32_t>(payload));
  PutU32(out, Crc32(out.data() + start, out.size() - start));
}

// zlib (RFC 1950) stream of data appended to out. Z_HUFFMAN_ONLY: speckle offers entropy
// coding and little else; on marina pings it is as small as Z_RLE (ratio 0.584) and faster.
void DeflateAppend(const std::vector<std::uint8_t>& data, int level,
                   std::vector<std::uint8_t>& out) {
  z_stream zs{};
  if (deflateInit2(&zs, level, Z_DEFLATED, 15, 8, Z_HUFFMAN_ONLY) != Z_OK) {
    throw std::runtime_error("zlib deflateInit2 failed");
  }
  const std::size_t start = out.size();
  out.resize(start + deflateBound(&zs, static_cast<uLong>(data.size())));
  zs.next_in = const_cast<Bytef*>(data.data());
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = out.data() + start;
  zs.avail_out = static_cast<uInt>(out.size() - start);
  const int result = deflate(&zs, Z_FINISH);
  const std::size_t written = zs.total_out;
  deflateEnd(&zs);
  if (result != Z_STREAM_END) throw std::runtime_error("zlib deflate failed");
  out.resize(start + written);
}

// A block is ended every kZstdBlockBytes, so each may bring its own Huffman table for the
// literals: speckle's statistics change with range. On marina pings (recording_read_bench
// --recode) 16 KiB blocks are 0.586 of raw against 0.602 with zstd's 128 KiB blocks (zlib
// level 1, 16 KiB blocks too: 0.584); decoding takes 0.35 against 0.28 ms a ping, encoding
// 0.99 against 0.46 ms (docs/recording-format.md section 10).
constexpr std::size_t kZstdBlockBytes = 16384;

// Appends one zstd frame of data[0, size), stating its content size; returns its bytes, 0 on
// a zstd error (out is then left as it was).
std::size_t ZstdAppend(ZSTD_CCtx* context, const std::uint8_t* data, std::size_t size,
                       std::vector<std::uint8_t>& out) {
  const std::size_t start = out.size();
  ZSTD_CCtx_reset(context, ZSTD_reset_session_only);
  if (ZSTD_isError(ZSTD_CCtx_setPledgedSrcSize(context, size))) return 0;
  // Each flushed block costs at most a few bytes beyond ZSTD_compressBound.
  out.resize(start + ZSTD_compressBound(size) + 16 * (size / kZstdBlockBytes + 1));
  ZSTD_outBuffer output{out.data() + start, out.size() - start, 0};
  std::size_t at = 0;
  do {
    const std::size_t n = std::min(kZstdBlockBytes, size - at);
    ZSTD_inBuffer input{data + at, n, 0};
    at += n;
    const ZSTD_EndDirective end = at == size ? ZSTD_e_end : ZSTD_e_flush;
    const std::size_t left = ZSTD_compressStream2(context, &output, &input, end);
    if (ZSTD_isError(left) || left != 0 || input.pos != n) {
      out.resize(start);
      ZSTD_CCtx_reset(context, ZSTD_reset_session_only);
      return 0;
    }
  } while (at < size);
  out.resize(start + output.pos);
  return output.pos;
}

}  // namespace

void EncodeSonarFileHeader(std::vector<std::uint8_t>& out) {
  out.insert(out.end(), kSonarFileMagic, kSonarFileMagic + 8);
  PutU32(out, kSonarFileVersion);
  PutU32(out, 0);  // file flags, reserved
}

struct PingEncoder::Zstd {
  Zstd() : context(ZSTD_createCCtx()) {
    if (context == nullptr) throw std::bad_alloc();
  }
  ~Zstd() { ZSTD_freeCCtx(context); }
  Zstd(const Zstd&) = delete;
  Zstd& operator=(const Zstd&) = delete;
  ZSTD_CCtx* context;
};

std::string ValidateWriterOptions(const WriterOptions& options) {
  if (options.ping_quantization_step < 1 || options.ping_quantization_step > kMaxQuantizationStep) {
    return "ping_quantization_step " + std::to_string(options.ping_quantization_step) +
           " is not in 1.." + std::to_string(kMaxQuantizationStep);
  }
  const int level = options.compression_level;
  switch (options.compression) {
    case ImageCompression::kRaw:
      return "";
    case ImageCompression::kPng:
    case ImageCompression::kZlib:
      if (level < 1 || level > 9) {
        return "compression_level " + std::to_string(level) + " is not a zlib level (1..9)";
      }
      return "";
    case ImageCompression::kZstd:
      if (level < ZSTD_minCLevel() || level > ZSTD_maxCLevel()) {
        return "compression_level " + std::to_string(level) + " is not a zstd level (" +
               std::to_string(ZSTD_minCLevel()) + ".." + std::to_string(ZSTD_maxCLevel()) + ")";
      }
      return "";
  }
  return "unknown compression " + std::to_string(static_cast<int>(options.compression)) +
         ", expected 0 (raw), 1 (PNG), 2 (zlib) or 3 (zstd)";
}

PingEncoder::PingEncoder(const WriterOptions& options) : options_(options) {
  if (const std::string problem = ValidateWriterOptions(options); !problem.empty()) {
    throw std::invalid_argument("WriterOptions: " + problem);
  }
  if (options.compression == ImageCompression::kZstd) {
    zstd_ = std::make_unique<Zstd>();
    // One frame stating its content size (the reader checks it before allocating); no zstd
    // checksum, the record's CRC-32 covers the bytes.
    for (const auto& [parameter, value] :
         {std::pair{ZSTD_c_compressionLevel, options.compression_level},
          std::pair{ZSTD_c_contentSizeFlag, 1}, std::pair{ZSTD_c_checksumFlag, 0}}) {
      const std::size_t result = ZSTD_CCtx_setParameter(zstd_->context, parameter, value);
      if (ZSTD_isError(result)) {
        throw std::invalid_argument(std::string("WriterOptions: zstd refuses a parameter: ") +
                                    ZSTD_getErrorName(result));
      }
    }
  }
}

PingEncoder::~PingEncoder() = default;

void PingEncoder::EncodePingRecord(const msgs::SonarPing& ping, bool include_bearings,
                                   std::vector<std::uint8_t>& out) {
  const WriterOptions& options = options_;
  const std::size_t start = BeginRecord(out, kRecordPing);
  PutF64(out, ping.time_s);
  PutU32(out, ping.ping_id);
  PutU32(out, static_cast<std::uint32_t>(ping.num_ranges));
  PutU32(out, static_cast<std::uint32_t>(ping.num_beams));
  PutF64(out, ping.range_resolution_m);
  PutF64(out, ping.vertical_aperture_rad);
  PutU8(out, include_bearings ? kPingHasBearings : 0);
  const std::size_t encoding_at = out.size();
  PutU8(out, static_cast<std::uint8_t>(options.compression));
  const int step = options.ping_quantization_step;
  PutU16(out, static_cast<std::uint16_t>(step > 1 ? step : 0));  // 0: the exact image
  if (step > 1) {
    quantized_.resize(ping.intensity.size());
    for (std::size_t i = 0; i < ping.intensity.size(); ++i) {
      quantized_[i] =
          static_cast<std::uint8_t>(std::min(255, step * ((ping.intensity[i] + step / 2) / step)));
    }
  }
  const std::vector<std::uint8_t>& intensity = step > 1 ? quantized_ : ping.intensity;
  if (include_bearings) {
    for (float bearing : ping.bearings_rad) PutF32(out, bearing);
  }
  const std::size_t size_at = out.size();
  PutU32(out, 0);
  const std::size_t image_at = out.size();
  if (options.compression == ImageCompression::kPng) {
    const cv::Mat image(ping.num_ranges, ping.num_beams, CV_8UC1,
                        const_cast<std::uint8_t*>(intensity.data()));
    std::vector<std::uint8_t> png;
    // The RLE strategy is about twice as fast as the default on speckle, and no larger.
    if (!cv::imencode(".png", image, png,
                      {cv::IMWRITE_PNG_COMPRESSION, options.compression_level,
                       cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_RLE})) {
      throw std::runtime_error("PNG encoding of ping " + std::to_string(ping.ping_id) + " failed");
    }
    out.insert(out.end(), png.begin(), png.end());
  } else if (options.compression == ImageCompression::kZlib) {
    if (options.compression_level == 1) {  // same stream shape as zlib's, 2-3x faster
      HuffmanDeflateAppend(intensity.data(), intensity.size(), out);
    } else {
      DeflateAppend(intensity, options.compression_level, out);
    }
  } else if (options.compression == ImageCompression::kZstd) {
    const std::size_t cells = intensity.size();
    const std::size_t written = ZstdAppend(zstd_->context, intensity.data(), cells, out);
    if (written == 0) {
      throw std::runtime_error("zstd compression of ping " + std::to_string(ping.ping_id) +
                               " failed");
    }
    // A near-constant image can beat 1032:1, the most the format allows a compressed image
    // (the reader's memory bound, kMaxDeflateRatio): stored as zlib instead, at most 8:1.
    if (cells / kMaxDeflateRatio > written) {
      out.resize(image_at);
      out[encoding_at] = static_cast<std::uint8_t>(ImageCompression::kZlib);
      HuffmanDeflateAppend(intensity.data(), cells, out);
    }
  } else if (options.compression == ImageCompression::kRaw) {
    out.insert(out.end(), intensity.begin(), intensity.end());
  } else {
    throw std::invalid_argument("unknown ImageCompression value");
  }
  SetU32(out, size_at, static_cast<std::uint32_t>(out.size() - image_at));
  FinishRecord(out, start);
}

void EncodeEndRecord(std::uint64_t ping_count, std::vector<std::uint8_t>& out) {
  const std::size_t start = BeginRecord(out, kRecordEnd);
  PutU64(out, ping_count);
  FinishRecord(out, start);
}

namespace {

std::string Hex(std::uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof(text), "0x%08x", v);
  return text;
}

std::uint32_t GetU32BigEndian(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

// "" when png (size bytes) starts with the PNG signature and an IHDR chunk of width beams,
// height ranges, bit depth 8 and colour type 0 (grey); else what is wrong.
std::string CheckPngHeader(const std::uint8_t* png, std::size_t size, std::uint32_t ranges,
                           std::uint32_t beams) {
  static constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < 8 + 8 + 13 || std::memcmp(png, kSignature, 8) != 0 || GetU32BigEndian(png + 8) != 13 ||
      std::memcmp(png + 12, "IHDR", 4) != 0) {
    return "PNG image has no PNG signature and header (IHDR)";
  }
  const std::uint32_t width = GetU32BigEndian(png + 16);
  const std::uint32_t height = GetU32BigEndian(png + 20);
  const int depth = png[24];
  const int colour = png[25];
  if (width != beams || height != ranges || depth != 8 || colour != 0) {
    return "PNG header announces " + std::to_string(height) + " x " + std::to_string(width) +
           " pixels of bit depth " + std::to_string(depth) + ", colour type " +
           std::to_string(colour) + "; expected " + std::to_string(ranges) + " x " +
           std::to_string(beams) + " 8-bit grey (colour type 0)";
  }
  return "";
}

std::string Printable(const std::uint8_t* p, std::size_t n) {
  std::string text;
  for (std::size_t i = 0; i < n; ++i) {
    const char c = static_cast<char>(p[i]);
    text += (c >= 32 && c < 127) ? c : '.';
  }
  return text;
}

class SonarStream final : public Stream {
 public:
  explicit SonarStream(const fs::path& path) : path_(path), file_(path, std::ios::binary) {
    std::error_code error;
    if (!fs::is_regular_file(path, error) || !file_) {
      throw RecordingError(path_.string() + ": missing or unreadable (expected the robot's " +
                           "sonar pings)");
    }
    // Record lengths are checked against what the file holds before anything is allocated.
    file_size_ = fs::file_size(path, error);
    if (error) file_size_ = 0;
    std::uint8_t header[kFileHeaderBytes];
    const std::size_t got = Read(header, sizeof(header));
    if (got < sizeof(header)) {
      Fail("truncated file header: " + std::to_string(got) + " of " +
           std::to_string(kFileHeaderBytes) + " bytes");
    }
    if (std::memcmp(header, kSonarFileMagic, 8) != 0) {
      Fail("bad file magic '" + Printable(header, 8) + "', expected 'DRACOSNR' (not a draco " +
           "sonar file)");
    }
    const std::uint32_t version = GetU32(header + 8);
    if (version != kSonarFileVersion) {
      Fail("unsupported sonar file version " + std::to_string(version) +
           ", this reader reads version " + std::to_string(kSonarFileVersion));
    }
    offset_ = kFileHeaderBytes;
  }

  std::optional<Record> Next() override {
    if (ended_) return std::nullopt;
    const std::uint64_t record_offset = offset_;
    std::uint8_t header[kRecordHeaderBytes];
    const std::size_t got = Read(header, sizeof(header));
    if (got == 0) {
      FailRecord(record_offset, "truncated file: ends after " + std::to_string(pings_) +
                                    " pings without the end record");
    }
    if (got < sizeof(header)) {
      FailRecord(record_offset, "truncated record header: " + std::to_string(got) + " of " +
                                    std::to_string(kRecordHeaderBytes) + " bytes");
    }
    if (std::memcmp(header, kRecordMagic, 4) != 0) {
      FailRecord(record_offset, "bad record magic '" + Printable(header, 4) + "', expected 'DREC'");
    }
    const std::uint16_t type = GetU16(header + 4);
    const std::uint32_t length = GetU32(header + 8);
    if (length > kMaxPayloadBytes) {
      FailRecord(record_offset,
                 "implausible payload length " + std::to_string(length) + " bytes (limit 256 MiB)");
    }
    // The buffer never exceeds the file: a record header claiming more than is left is a
    // truncated file, reported before allocating (a 30-byte file cannot make 256 MiB).
    const std::uint64_t left = file_size_ > offset_ ? file_size_ - offset_ : 0;
    if (std::uint64_t{length} + 4 > left) {
      FailRecord(record_offset, "truncated record: payload and CRC need " +
                                    std::to_string(std::uint64_t{length} + 4) +
                                    " bytes, file has " + std::to_string(left));
    }
    record_.resize(8 + static_cast<std::size_t>(length) + 4);
    std::memcpy(record_.data(), header + 4, 8);
    const std::size_t body = Read(record_.data() + 8, length + 4);
    if (body < length + 4) {
      FailRecord(record_offset, "truncated record: payload and CRC need " +
                                    std::to_string(length + 4) + " bytes, file has " +
                                    std::to_string(body));
    }
    const std::uint32_t stored = GetU32(record_.data() + 8 + length);
    const std::uint32_t computed = Crc32(record_.data(), 8 + length);
    if (stored != computed) {
      FailRecord(record_offset, "bad CRC: stored " + Hex(stored) + ", computed " + Hex(computed));
    }
    const std::uint8_t* payload = record_.data() + 8;
    if (type == kRecordEnd) {
      if (length != 8) FailRecord(record_offset, "end record payload must be 8 bytes");
      const std::uint64_t count = GetU64(payload);
      if (count != pings_) {
        FailRecord(record_offset, "end record counts " + std::to_string(count) +
                                      " pings, file holds " + std::to_string(pings_));
      }
      std::uint8_t extra = 0;
      if (Read(&extra, 1) != 0) {
        FailRecord(offset_ - 1, "unexpected data after the end record");
      }
      ended_ = true;
      return std::nullopt;
    }
    if (type != kRecordPing) {
      FailRecord(record_offset,
                 "unknown record type " + std::to_string(type) + ", expected 1 (ping) or 2 (end)");
    }
    Record result = DecodePing(payload, length, record_offset);
    ++pings_;
    ++records_;
    return result;
  }

 private:
  msgs::SonarPing DecodePing(const std::uint8_t* p, std::uint32_t length,
                             std::uint64_t record_offset) {
    auto fail = [&](const std::string& what) { FailRecord(record_offset, what); };
    if (length < kPingFixedBytes + 4) fail("ping payload too short");
    msgs::SonarPing ping;
    ping.time_s = GetF64(p);
    ping.ping_id = GetU32(p + 8);
    const std::uint32_t ranges = GetU32(p + 12);
    const std::uint32_t beams = GetU32(p + 16);
    ping.range_resolution_m = GetF64(p + 20);
    ping.vertical_aperture_rad = GetF64(p + 28);
    const std::uint8_t flags = p[36];
    const std::uint8_t encoding = p[37];
    if (!std::isfinite(ping.time_s)) fail("ping time is not finite");
    if (ping.time_s < last_time_) {
      fail("ping time " + FormatDouble(ping.time_s) + " s is before the previous ping's " +
           FormatDouble(last_time_) + " s");
    }
    if (ranges == 0 || beams == 0 || ranges > kMaxImageSide || beams > kMaxImageSide ||
        static_cast<std::uint64_t>(ranges) * beams > kMaxImageCells) {
      fail("implausible image size " + std::to_string(ranges) + " x " + std::to_string(beams));
    }
    if (!(std::isfinite(ping.range_resolution_m) && ping.range_resolution_m > 0)) {
      fail("range resolution must be a positive number");
    }
    if ((flags & ~kPingHasBearings) != 0) fail("unknown ping flags " + std::to_string(flags));
    if (const std::uint16_t step = GetU16(p + 38); step > kMaxQuantizationStep) {
      fail("ping quantization step " + std::to_string(step) + " is not in 0.." +
           std::to_string(kMaxQuantizationStep));
    }
    ping.num_ranges = static_cast<int>(ranges);
    ping.num_beams = static_cast<int>(beams);

    std::size_t at = kPingFixedBytes;
    if (flags & kPingHasBearings) {
      if (length < at + 4ull * beams + 4) fail("ping payload too short for its bearing table");
      bearings_.resize(beams);
      for (std::uint32_t i = 0; i < beams; ++i) bearings_[i] = GetF32(p + at + 4 * i);
      at += 4ull * beams;
    } else if (bearings_.empty()) {
      fail("no bearing table: the first ping must carry one");
    } else if (bearings_.size() != beams) {
      fail("no bearing table although the beam count changed from " +
           std::to_string(bearings_.size()) + " to " + std::to_string(beams));
    }
    ping.bearings_rad = bearings_;

    const std::uint32_t image_size = GetU32(p + at);
    at += 4;
    if (at + image_size != length) {
      fail("image size " + std::to_string(image_size) + " does not fill the payload (" +
           std::to_string(length - at) + " bytes left)");
    }
    const std::size_t cells = static_cast<std::size_t>(ranges) * beams;
    // Deflate (zlib and PNG) expands at most 1032:1, so a compressed image smaller than
    // cells / 1032 cannot be whole: refused before the image is allocated. The image buffer is
    // thus at most 1032 times the record's bytes.
    // zstd can expand further; the format holds a zstd image to the same bound.
    const bool zstd = encoding == static_cast<std::uint8_t>(ImageCompression::kZstd);
    if (encoding != static_cast<std::uint8_t>(ImageCompression::kRaw) &&
        cells / kMaxDeflateRatio > image_size) {
      fail(std::to_string(image_size) + "-byte compressed image cannot hold " +
           std::to_string(ranges) + " x " + std::to_string(beams) + " pixels (" +
           (zstd ? "a zstd image may expand" : "deflate expands") + " at most " +
           std::to_string(kMaxDeflateRatio) + ":1)");
    }
    if (encoding == static_cast<std::uint8_t>(ImageCompression::kRaw)) {
      if (image_size != cells) {
        fail("raw image has " + std::to_string(image_size) + " bytes, expected " +
             std::to_string(cells));
      }
      ping.intensity.assign(p + at, p + at + cells);
    } else if (encoding == static_cast<std::uint8_t>(ImageCompression::kPng)) {
      // The PNG header must announce the ping's size, 8-bit grey, before OpenCV allocates what
      // it announces.
      if (const std::string problem = CheckPngHeader(p + at, image_size, ranges, beams);
          !problem.empty()) {
        fail(problem);
      }
      const cv::Mat encoded(1, static_cast<int>(image_size), CV_8UC1,
                            const_cast<std::uint8_t*>(p + at));
      cv::Mat image;
      try {
        image = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
      } catch (const cv::Exception&) {
        image = cv::Mat();
      }
      if (image.empty() || image.type() != CV_8UC1 || image.rows != ping.num_ranges ||
          image.cols != ping.num_beams) {
        fail("PNG image does not decode to " + std::to_string(ranges) + " x " +
             std::to_string(beams) + " 8-bit grey");
      }
      ping.intensity.resize(cells);
      for (int r = 0; r < image.rows; ++r) {
        std::memcpy(ping.intensity.data() + static_cast<std::size_t>(r) * beams, image.ptr(r),
                    beams);
      }
    } else if (encoding == static_cast<std::uint8_t>(ImageCompression::kZlib)) {
      ping.intensity.resize(cells);
      uLongf produced = static_cast<uLongf>(cells);
      const int result = uncompress(ping.intensity.data(), &produced, p + at, image_size);
      if (result != Z_OK || produced != cells) {
        fail("zlib image does not inflate to " + std::to_string(ranges) + " x " +
             std::to_string(beams) + " bytes (" +
             (result == Z_BUF_ERROR ? std::string("too much or too little data")
                                    : std::string(zError(result))) +
             ")");
      }
    } else if (zstd) {
      DecodeZstd(p + at, image_size, ranges, beams, ping.intensity, fail);
    } else {
      fail("unknown image encoding " + std::to_string(encoding) +
           ", expected 0 (raw), 1 (PNG), 2 (zlib) or 3 (zstd)");
    }
    last_time_ = ping.time_s;
    return ping;
  }

  // One zstd frame stating R x B bytes of content, nothing after it. The sizes are checked
  // before the image is allocated.
  template <typename Fail>
  void DecodeZstd(const std::uint8_t* frame, std::uint32_t frame_size, std::uint32_t ranges,
                  std::uint32_t beams, std::vector<std::uint8_t>& image, const Fail& fail) {
    const std::size_t cells = static_cast<std::size_t>(ranges) * beams;
    const std::string expected =
        std::to_string(ranges) + " x " + std::to_string(beams) + " = " + std::to_string(cells);
    const unsigned long long content = ZSTD_getFrameContentSize(frame, frame_size);
    if (content == ZSTD_CONTENTSIZE_ERROR) {
      fail("zstd image is not a zstd frame (bad magic number or frame header)");
    }
    if (content == ZSTD_CONTENTSIZE_UNKNOWN) {
      fail("zstd frame header does not state its content size (expected " + expected + " bytes)");
    }
    if (content != cells) {
      fail("zstd frame holds " + std::to_string(content) + " bytes, expected " + expected);
    }
    const std::size_t frame_bytes = ZSTD_findFrameCompressedSize(frame, frame_size);
    if (ZSTD_isError(frame_bytes)) {
      fail("zstd frame is truncated or corrupt (" + std::string(ZSTD_getErrorName(frame_bytes)) +
           ")");
    }
    if (frame_bytes != frame_size) {
      fail("zstd image has " + std::to_string(frame_size - frame_bytes) +
           " bytes after its frame (expected exactly one frame)");
    }
    if (!zstd_) {
      zstd_.reset(ZSTD_createDCtx());
      if (!zstd_) throw std::bad_alloc();
    }
    image.resize(cells);
    const std::size_t produced =
        ZSTD_decompressDCtx(zstd_.get(), image.data(), cells, frame, frame_size);
    if (ZSTD_isError(produced) || produced != cells) {
      fail("zstd frame does not decompress to " + expected + " bytes (" +
           (ZSTD_isError(produced) ? std::string(ZSTD_getErrorName(produced))
                                   : std::to_string(produced) + " bytes") +
           ")");
    }
  }

  std::size_t Read(std::uint8_t* data, std::size_t size) {
    file_.read(reinterpret_cast<char*>(data), static_cast<std::streamsize>(size));
    const auto got = static_cast<std::size_t>(file_.gcount());
    offset_ += got;
    return got;
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw RecordingError(path_.string() + ": " + what);
  }

  [[noreturn]] void FailRecord(std::uint64_t offset, const std::string& what) const {
    throw RecordingError(path_.string() + ": record " + std::to_string(records_) +
                         " (byte offset " + std::to_string(offset) + "): " + what);
  }

  fs::path path_;
  std::ifstream file_;
  std::uint64_t file_size_ = 0;
  std::uint64_t offset_ = 0;
  std::uint64_t records_ = 0;
  std::uint64_t pings_ = 0;
  double last_time_ = -INFINITY;
  bool ended_ = false;
  std::vector<std::uint8_t> record_;
  std::vector<float> bearings_;
  struct FreeZstd {
    void operator()(ZSTD_DCtx* context) const { ZSTD_freeDCtx(context); }
  };
  std::unique_ptr<ZSTD_DCtx, FreeZstd> zstd_;  // made at the first zstd image, then reused
};

}  // namespace

std::unique_ptr<Stream> OpenSonarStream(const fs::path& path) {
  return std::make_unique<SonarStream>(path);
}

}  // namespace draco::recording::internal
