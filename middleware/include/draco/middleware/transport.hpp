// Transports carry link frames between robot processes (Cyclone DDS, or plain UDP datagrams to
// static peers: the modem-like link) or between robots in one process (an in-process bus, used
// by deterministic replay and tests). Both behave the same
// above this interface: the acoustic channel model (channel.hpp) decides when a frame is
// delivered; a transport only moves bytes, never blocks, and never throws on what a peer sent.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "draco/middleware/frame.hpp"

namespace draco::middleware {

struct TransportCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_received = 0;
  std::uint64_t frames_malformed = 0;  // dropped by the transport (bad size, bad envelope)
  std::uint64_t frames_own = 0;        // own frames echoed back, ignored
  std::uint64_t send_failed = 0;       // Send returned false (refused frame, DDS write error)
  // DDS: teammates' writers that stopped being alive (their participant left, crashed or was
  // cut off beyond its liveliness lease); 0 for the in-process bus.
  std::uint64_t peers_lost = 0;
};

class Transport {
 public:
  virtual ~Transport() = default;
  // Hands a frame to every other robot on the link (or to frame.destination). Never blocks
  // for long; returns false when the frame could not be handed over (counted).
  virtual bool Send(const Frame& frame) = 0;
  // Frames received since the last call, in arrival order; never blocks. The robot's own
  // frames are not returned.
  virtual std::vector<Frame> Receive() = 0;
  virtual std::string Describe() const = 0;  // "inproc:team" or "dds:domain 0"
  virtual TransportCounters counters() const = 0;
};

// In-process bus `bus` (created on first use, process-wide). Deterministic: a frame sent is
// in every other endpoint's inbox before Send returns, in send order.
std::unique_ptr<Transport> MakeInProcessTransport(const std::string& bus, std::uint16_t robot_id);

enum class DdsReliability { kReliable, kBestEffort };

// "reliable" or "best_effort"; throws std::invalid_argument naming the value and the choices.
DdsReliability ParseDdsReliability(const std::string& text);
const char* DdsReliabilityName(DdsReliability reliability);

// The DDS settings of a robot's link. Every robot of a team must use the same domain, topic
// prefix and reliability (a reliable reader does not match a best-effort writer).
struct DdsOptions {
  int domain_id = 0;  // 0 to 232; another domain is another team
  std::uint16_t robot_id = 0;
  // Cyclone DDS configuration (XML file); "" uses $CYCLONEDDS_URI or Cyclone's defaults.
  std::string config_file;
  // Prepended to the topic name "draco_link" (letters, digits and '_'; may be empty): teams
  // with different prefixes share a domain and a network without hearing each other.
  std::string topic_prefix;
  DdsReliability reliability = DdsReliability::kReliable;
  // Keep-last history per writer (one per robot) on both sides; deep enough that a reader
  // busy for a long optimisation step loses nothing of a teammate that keeps ticking.
  int history_depth = 1024;  // 1 to 100000
  // > 0: every writer offers automatic liveliness with this lease, so a teammate whose
  // process died or whose network went away is noticed (TransportCounters::peers_lost) about
  // this long after it stopped; 0: no lease (a writer that leaves cleanly is still noticed).
  double liveliness_lease_s = 0.0;
};

// The topic name: topic_prefix + "draco_link".
std::string DdsTopicName(const DdsOptions& options);

// Checks every field; throws std::invalid_argument naming the field, the value and what was
// expected.
void ValidateDdsOptions(const DdsOptions& options);

// Cyclone DDS (C API) transport: one participant, one keep-last topic of link frames
// (middleware/idl/link.idl) with the QoS of `options`. Throws std::invalid_argument for a bad
// option (ValidateDdsOptions) and std::runtime_error when DDS cannot start (the message
// names the domain and the config file).
std::unique_ptr<Transport> MakeDdsTransport(const DdsOptions& options);

// The settings of a robot's plain-UDP link: one datagram per frame to every peer, no
// discovery, no acknowledgements, no resends (the fleet link's own protocol resends what
// matters). What a team on a slow acoustic modem needs: DDS's discovery and reliability
// traffic alone fills 1 kbit/s (docs/fleet.md, "A team across network namespaces").
struct UdpOptions {
  std::uint16_t robot_id = 0;
  std::string bind_address = "0.0.0.0";  // IPv4 address to listen on
  int port = 7470;                       // UDP port to listen on (1 to 65535)
  // Every teammate as "host:port" or "host" (then `port`), IPv4 addresses or host names; may
  // list this robot too (its own datagrams come back and are counted as own). A frame for one
  // robot goes to the address that robot's frames came from once one has arrived, else to
  // every peer.
  std::vector<std::string> peers;
};

// Checks every field and resolves every peer; throws std::invalid_argument naming the field,
// the value and what was expected.
void ValidateUdpOptions(const UdpOptions& options);

// Plain UDP transport (IPv4). Throws std::invalid_argument for a bad option and
// std::runtime_error when the socket cannot be made or bound (the message names the address
// and port).
std::unique_ptr<Transport> MakeUdpTransport(const UdpOptions& options);

// The UDP datagram of a frame: magic "DRL", version 1, the Frame fields (little-endian,
// times as IEEE 754 doubles), the payload's length and bytes, and a CRC-32 of everything
// before it: kUdpDatagramOverheadBytes + payload bytes.
inline constexpr std::size_t kUdpDatagramOverheadBytes = 36;
std::vector<std::uint8_t> EncodeUdpDatagram(const Frame& frame);
// The frame in a datagram, or nothing when it is not one (short, wrong magic or version,
// length that does not match, CRC mismatch, kind 0, payload above kMaxPayloadBytes, a time
// that is not finite). Never throws, never reads outside [data, data + size).
std::optional<Frame> DecodeUdpDatagram(const std::uint8_t* data, std::size_t size);

}  // namespace draco::middleware
