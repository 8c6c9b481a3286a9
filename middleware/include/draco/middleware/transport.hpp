// Transports carry link frames between robot processes (Cyclone DDS) or between robots in one
// process (an in-process bus, used by deterministic replay and tests). Both behave the same
// above this interface: the acoustic channel model (channel.hpp) decides when a frame is
// delivered; a transport only moves bytes, never blocks, and never throws on what a peer sent.
#pragma once

#include <cstdint>
#include <memory>
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

struct DdsOptions {
  int domain_id = 0;
  std::uint16_t robot_id = 0;
  // Cyclone DDS configuration (XML file); "" uses $CYCLONEDDS_URI or Cyclone's defaults.
  std::string config_file;
  std::string topic = "draco_link";
};

// Cyclone DDS (C API) transport: one participant, one reliable keep-last topic of link
// frames (middleware/idl/link.idl). Throws std::runtime_error when DDS cannot start
// (message names the domain and the config file).
std::unique_ptr<Transport> MakeDdsTransport(const DdsOptions& options);

}  // namespace draco::middleware
