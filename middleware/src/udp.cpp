// Plain UDP transport: the modem-like link. One non-blocking IPv4 socket bound to the robot's
// port; every frame is one datagram (EncodeUdpDatagram) sent to every peer, or to the address
// a directed frame's robot was last heard from. Receive() drains the socket without blocking and
// validates every datagram (a peer, or anything else on the network, may send anything).
#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/middleware/transport.hpp"

namespace draco::middleware {
namespace {

constexpr std::uint8_t kMagic[3] = {'D', 'R', 'L'};
constexpr std::uint8_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 32;  // up to the payload
constexpr std::size_t kCrcBytes = 4;
static_assert(kHeaderBytes + kCrcBytes == kUdpDatagramOverheadBytes);
static_assert(kMaxPayloadBytes <= 0xFFFF, "the payload length is 16 bits");
// Datagrams taken per Receive() call at most, so one call cannot be held by a flood.
constexpr int kMaxDatagramsPerReceive = 4096;

// CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320), as zlib's crc32.
constexpr std::array<std::uint32_t, 256> MakeCrcTable() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}
constexpr auto kCrcTable = MakeCrcTable();

std::uint32_t Crc32(const std::uint8_t* data, std::size_t size) {
  std::uint32_t c = 0xFFFFFFFFU;
  for (std::size_t i = 0; i < size; ++i) c = kCrcTable[(c ^ data[i]) & 0xFFU] ^ (c >> 8);
  return c ^ 0xFFFFFFFFU;
}

void PutU16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void PutU32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void PutF64(std::uint8_t* p, double v) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(bits >> (8 * i));
}
std::uint16_t GetU16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t GetU32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}
double GetF64(const std::uint8_t* p) {
  std::uint64_t bits = 0;
  for (int i = 0; i < 8; ++i) bits |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  double v = 0.0;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

// "host:port" or "host" (default_port) to an IPv4 socket address; throws std::invalid_argument.
sockaddr_in ResolvePeer(const std::string& text, int default_port) {
  std::string host = text;
  int port = default_port;
  if (const auto colon = text.rfind(':'); colon != std::string::npos) {
    host = text.substr(0, colon);
    const std::string digits = text.substr(colon + 1);
    char* end = nullptr;
    const long p = digits.empty() ? -1 : std::strtol(digits.c_str(), &end, 10);
    if (digits.empty() || *end != '\0' || p < 1 || p > 65535) {
      throw std::invalid_argument("udp peer '" + text + "': port '" + digits +
                                  "': expected 1 to 65535");
    }
    port = static_cast<int>(p);
  }
  if (host.empty()) {
    throw std::invalid_argument("udp peer '" + text + "': expected host:port or host");
  }
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  if (const int rc = getaddrinfo(host.c_str(), nullptr, &hints, &found); rc != 0 || !found) {
    throw std::invalid_argument("udp peer '" + text + "': cannot resolve '" + host +
                                "' to an IPv4 address (" + gai_strerror(rc) + ")");
  }
  sockaddr_in addr{};
  std::memcpy(&addr, found->ai_addr, sizeof addr);
  freeaddrinfo(found);
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  return addr;
}

std::string Text(const sockaddr_in& addr) {
  char buf[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &addr.sin_addr, buf, sizeof buf);
  return std::string(buf) + ":" + std::to_string(ntohs(addr.sin_port));
}

bool Valid(const Frame& frame) {
  return frame.kind != 0 && frame.payload.size() <= kMaxPayloadBytes &&
         std::isfinite(frame.enqueued_s) && std::isfinite(frame.delivered_s);
}

class UdpTransport final : public Transport {
 public:
  explicit UdpTransport(const UdpOptions& options) : options_(options) {
    ValidateUdpOptions(options_);
    for (const auto& p : options_.peers) peers_.push_back(ResolvePeer(p, options_.port));
    sockaddr_in local{};
    local.sin_family = AF_INET;
    local.sin_port = htons(static_cast<std::uint16_t>(options_.port));
    inet_pton(AF_INET, options_.bind_address.c_str(), &local.sin_addr);
    where_ = options_.bind_address + ":" + std::to_string(options_.port);
    fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd_ < 0) {
      throw std::runtime_error("udp: cannot make a socket for " + where_ + ": " +
                               std::strerror(errno));
    }
    if (bind(fd_, reinterpret_cast<const sockaddr*>(&local), sizeof local) != 0) {
      const int e = errno;
      close(fd_);
      throw std::runtime_error("udp: cannot bind " + where_ + ": " + std::strerror(e));
    }
  }
  ~UdpTransport() override { close(fd_); }
  UdpTransport(const UdpTransport&) = delete;
  UdpTransport& operator=(const UdpTransport&) = delete;

  bool Send(const Frame& frame) override {
    std::lock_guard lock(mutex_);
    if (!Valid(frame)) {
      ++counters_.send_failed;
      return false;
    }
    Frame own = frame;
    own.source = options_.robot_id;
    const auto bytes = EncodeUdpDatagram(own);
    std::vector<sockaddr_in> targets;
    if (const auto it = heard_at_.find(frame.destination);
        frame.destination != kBroadcast && it != heard_at_.end()) {
      targets.push_back(it->second);
    } else {
      targets = peers_;
    }
    bool any = false;
    for (const auto& to : targets) {
      const ssize_t n = sendto(fd_, bytes.data(), bytes.size(), MSG_DONTWAIT,
                               reinterpret_cast<const sockaddr*>(&to), sizeof to);
      any = any || n == static_cast<ssize_t>(bytes.size());
    }
    if (!any && !targets.empty()) {
      ++counters_.send_failed;
      return false;
    }
    ++counters_.frames_sent;
    return true;
  }

  std::vector<Frame> Receive() override {
    std::vector<Frame> out;
    std::lock_guard lock(mutex_);
    for (int i = 0; i < kMaxDatagramsPerReceive; ++i) {
      sockaddr_in from{};
      socklen_t from_len = sizeof from;
      const ssize_t n = recvfrom(fd_, buffer_.data(), buffer_.size(), MSG_DONTWAIT,
                                 reinterpret_cast<sockaddr*>(&from), &from_len);
      if (n < 0) {
        if (errno == EINTR) continue;
        break;  // EAGAIN: nothing more; anything else is not a peer's fault either
      }
      auto frame = DecodeUdpDatagram(buffer_.data(), static_cast<std::size_t>(n));
      if (!frame) {
        ++counters_.frames_malformed;
        continue;
      }
      if (frame->source == options_.robot_id) {
        ++counters_.frames_own;
        continue;
      }
      if (from_len == sizeof from && from.sin_family == AF_INET) heard_at_[frame->source] = from;
      if (frame->destination != kBroadcast && frame->destination != options_.robot_id) continue;
      ++counters_.frames_received;
      out.push_back(std::move(*frame));
    }
    return out;
  }

  std::string Describe() const override {
    std::string s = "udp:" + where_ + ", peers";
    for (const auto& p : peers_) s += " " + Text(p);
    return s;
  }

  TransportCounters counters() const override {
    std::lock_guard lock(mutex_);
    return counters_;
  }

 private:
  UdpOptions options_;
  std::vector<sockaddr_in> peers_;
  std::string where_;
  int fd_ = -1;
  mutable std::mutex mutex_;
  TransportCounters counters_;
  std::map<std::uint16_t, sockaddr_in> heard_at_;  // robot id -> where its frames came from
  std::array<std::uint8_t, 65536> buffer_{};
};

}  // namespace

std::vector<std::uint8_t> EncodeUdpDatagram(const Frame& frame) {
  const std::size_t n = frame.payload.size();
  if (n > kMaxPayloadBytes) {
    throw std::invalid_argument("udp: payload of " + std::to_string(n) + " bytes: at most " +
                                std::to_string(kMaxPayloadBytes));
  }
  std::vector<std::uint8_t> out(kHeaderBytes + n + kCrcBytes);
  std::uint8_t* p = out.data();
  std::memcpy(p, kMagic, 3);
  p[3] = kVersion;
  PutU16(p + 4, frame.source);
  PutU16(p + 6, frame.destination);
  p[8] = frame.kind;
  p[9] = frame.priority;
  PutU32(p + 10, frame.seq);
  PutF64(p + 14, frame.enqueued_s);
  PutF64(p + 22, frame.delivered_s);
  PutU16(p + 30, static_cast<std::uint16_t>(n));
  if (n > 0) std::memcpy(p + kHeaderBytes, frame.payload.data(), n);
  PutU32(p + kHeaderBytes + n, Crc32(p, kHeaderBytes + n));
  return out;
}

std::optional<Frame> DecodeUdpDatagram(const std::uint8_t* data, std::size_t size) {
  if (data == nullptr || size < kUdpDatagramOverheadBytes) return std::nullopt;
  if (std::memcmp(data, kMagic, 3) != 0 || data[3] != kVersion) return std::nullopt;
  const std::size_t n = GetU16(data + 30);
  if (n > kMaxPayloadBytes || size != kUdpDatagramOverheadBytes + n) return std::nullopt;
  if (GetU32(data + kHeaderBytes + n) != Crc32(data, kHeaderBytes + n)) return std::nullopt;
  Frame f;
  f.source = GetU16(data + 4);
  f.destination = GetU16(data + 6);
  f.kind = data[8];
  f.priority = data[9];
  f.seq = GetU32(data + 10);
  f.enqueued_s = GetF64(data + 14);
  f.delivered_s = GetF64(data + 22);
  if (!Valid(f)) return std::nullopt;
  f.payload.assign(data + kHeaderBytes, data + kHeaderBytes + n);
  return f;
}

void ValidateUdpOptions(const UdpOptions& o) {
  in_addr bind_addr{};
  if (inet_pton(AF_INET, o.bind_address.c_str(), &bind_addr) != 1) {
    throw std::invalid_argument("udp bind_address '" + o.bind_address +
                                "': expected an IPv4 address such as 0.0.0.0");
  }
  if (o.port < 1 || o.port > 65535) {
    throw std::invalid_argument("udp port " + std::to_string(o.port) + ": expected 1 to 65535");
  }
  if (o.peers.empty()) {
    throw std::invalid_argument("udp peers: empty; expected every teammate as host:port or host");
  }
  for (const auto& p : o.peers) ResolvePeer(p, o.port);
}

std::unique_ptr<Transport> MakeUdpTransport(const UdpOptions& options) {
  return std::make_unique<UdpTransport>(options);
}

}  // namespace draco::middleware
