// Cyclone DDS transport: the C API wrapped once. One participant per transport, one topic of
// link frames (middleware/idl/link.idl, keyed by the source robot), a reliable keep-last
// writer and reader, volatile durability. Receive() takes whatever arrived without blocking,
// validates every sample (a peer may send anything) and returns only frames for this robot
// or broadcast; own frames (same participant or another process with our id) are counted.
#include <dds/dds.h>

#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "draco/middleware/transport.hpp"
#include "link.h"

namespace draco::middleware {
namespace {

// Deep enough that a reader busy for seconds (a long optimisation step) loses nothing of a
// teammate that keeps ticking: a robot sends a few frames per 0.5 s tick.
constexpr std::int32_t kHistoryDepth = 1024;
constexpr std::uint32_t kTakeBatch = 32;

std::string Where(const DdsOptions& options) {
  return "domain " + std::to_string(options.domain_id) + ", config " +
         (options.config_file.empty() ? std::string("default ($CYCLONEDDS_URI or built-in)")
                                      : "'" + options.config_file + "'");
}

[[noreturn]] void Fail(const std::string& what, dds_return_t rc, const DdsOptions& options) {
  throw std::runtime_error("dds: " + what + " failed: " + dds_strretcode(rc) + " (" +
                           Where(options) + ")");
}

std::string ReadConfig(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  if (in) text << in.rdbuf();
  if (!in || text.str().empty()) {
    throw std::runtime_error("dds: cannot read the Cyclone DDS configuration file '" + path + "'");
  }
  return text.str();
}

// Domains created with an explicit configuration, shared by the transports of this process
// (Cyclone allows one dds_create_domain per domain id and process).
class Domains {
 public:
  static Domains& Get() {
    static Domains domains;
    return domains;
  }

  void Acquire(const DdsOptions& options) {
    std::string config = options.config_file.empty() ? "" : ReadConfig(options.config_file);
    std::lock_guard lock(mutex_);
    auto it = open_.find(options.domain_id);
    if (it != open_.end()) {
      if (it->second.config != config) {
        throw std::runtime_error("dds: domain " + std::to_string(options.domain_id) +
                                 " is already open in this process with another configuration (" +
                                 Where(options) + ")");
      }
      ++it->second.users;
      return;
    }
    dds_entity_t domain = 0;
    if (!config.empty()) {
      domain = dds_create_domain(static_cast<dds_domainid_t>(options.domain_id), config.c_str());
      if (domain < 0) Fail("dds_create_domain", domain, options);
    }
    open_.emplace(options.domain_id, Open{domain, std::move(config), 1});
  }

  void Release(int domain_id) {
    std::lock_guard lock(mutex_);
    auto it = open_.find(domain_id);
    if (it == open_.end() || --it->second.users > 0) return;
    if (it->second.domain > 0) dds_delete(it->second.domain);
    open_.erase(it);
  }

 private:
  struct Open {
    dds_entity_t domain;  // 0: created implicitly by the participant (default config)
    std::string config;
    int users;
  };
  std::mutex mutex_;
  std::map<int, Open> open_;
};

struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};

class DdsTransport final : public Transport {
 public:
  explicit DdsTransport(const DdsOptions& options) : options_(options) {
    if (options.domain_id < 0 || options.domain_id > 232) {
      throw std::runtime_error("dds: domain id must be in [0, 232] (" + Where(options) + ")");
    }
    Domains::Get().Acquire(options_);
    try {
      Start();
    } catch (...) {
      Stop();
      throw;
    }
  }

  ~DdsTransport() override { Stop(); }

  bool Send(const Frame& frame) override {
    if (frame.kind == 0 || frame.payload.size() > kMaxPayloadBytes) {
      std::lock_guard lock(mutex_);
      ++counters_.send_failed;
      return false;
    }
    draco_link_LinkFrame sample{};
    sample.source = options_.robot_id;
    sample.destination = frame.destination;
    sample.kind = frame.kind;
    sample.priority = frame.priority;
    sample.seq = frame.seq;
    sample.enqueued_s = frame.enqueued_s;
    sample.delivered_s = frame.delivered_s;
    const auto size = static_cast<std::uint32_t>(frame.payload.size());
    sample.payload._maximum = size;
    sample.payload._length = size;
    sample.payload._buffer = const_cast<std::uint8_t*>(frame.payload.data());  // only read
    sample.payload._release = false;
    const dds_return_t rc = dds_write(writer_, &sample);
    std::lock_guard lock(mutex_);
    if (rc != DDS_RETCODE_OK) {
      ++counters_.send_failed;
      return false;
    }
    ++counters_.frames_sent;
    return true;
  }

  std::vector<Frame> Receive() override {
    std::vector<Frame> out;
    TransportCounters delta;
    for (;;) {
      void* samples[kTakeBatch] = {};
      dds_sample_info_t infos[kTakeBatch];
      const dds_return_t n = dds_take(reader_, samples, infos, kTakeBatch, kTakeBatch);
      if (n <= 0) break;  // nothing (or an error: never thrown on what peers sent)
      for (dds_return_t i = 0; i < n; ++i) {
        if (!infos[i].valid_data) continue;  // instance state change (a writer left)
        const auto* s = static_cast<const draco_link_LinkFrame*>(samples[i]);
        if (s->source == options_.robot_id) {
          ++delta.frames_own;
          continue;
        }
        if (s->kind == 0 || s->payload._length > kMaxPayloadBytes ||
            (s->payload._length > 0 && s->payload._buffer == nullptr) ||
            !std::isfinite(s->enqueued_s) || !std::isfinite(s->delivered_s)) {
          ++delta.frames_malformed;
          continue;
        }
        if (s->destination != kBroadcast && s->destination != options_.robot_id) continue;
        Frame f;
        f.source = s->source;
        f.destination = s->destination;
        f.kind = s->kind;
        f.priority = s->priority;
        f.seq = s->seq;
        f.enqueued_s = s->enqueued_s;
        f.delivered_s = s->delivered_s;
        f.payload.assign(s->payload._buffer, s->payload._buffer + s->payload._length);
        out.push_back(std::move(f));
        ++delta.frames_received;
      }
      dds_return_loan(reader_, samples, n);
      if (static_cast<std::uint32_t>(n) < kTakeBatch) break;
    }
    std::lock_guard lock(mutex_);
    counters_.frames_received += delta.frames_received;
    counters_.frames_malformed += delta.frames_malformed;
    counters_.frames_own += delta.frames_own;
    return out;
  }

  std::string Describe() const override {
    return "dds:domain " + std::to_string(options_.domain_id);
  }

  TransportCounters counters() const override {
    std::lock_guard lock(mutex_);
    return counters_;
  }

 private:
  void Start() {
    participant_ =
        dds_create_participant(static_cast<dds_domainid_t>(options_.domain_id), nullptr, nullptr);
    if (participant_ < 0) Fail("dds_create_participant", participant_, options_);
    std::unique_ptr<dds_qos_t, QosDeleter> qos(dds_create_qos());
    dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kHistoryDepth);
    dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
    const dds_entity_t topic = dds_create_topic(participant_, &draco_link_LinkFrame_desc,
                                                options_.topic.c_str(), qos.get(), nullptr);
    if (topic < 0) Fail("dds_create_topic '" + options_.topic + "'", topic, options_);
    reader_ = dds_create_reader(participant_, topic, qos.get(), nullptr);
    if (reader_ < 0) Fail("dds_create_reader", reader_, options_);
    writer_ = dds_create_writer(participant_, topic, qos.get(), nullptr);
    if (writer_ < 0) Fail("dds_create_writer", writer_, options_);
  }

  void Stop() {
    if (participant_ > 0) dds_delete(participant_);  // deletes topic, reader, writer
    participant_ = 0;
    Domains::Get().Release(options_.domain_id);
  }

  DdsOptions options_;
  dds_entity_t participant_ = 0;
  dds_entity_t reader_ = 0;
  dds_entity_t writer_ = 0;
  mutable std::mutex mutex_;
  TransportCounters counters_;
};

}  // namespace

std::unique_ptr<Transport> MakeDdsTransport(const DdsOptions& options) {
  return std::make_unique<DdsTransport>(options);
}

}  // namespace draco::middleware
