// Cyclone DDS transport: the C API wrapped once. One participant per transport, one topic of
// link frames (middleware/idl/link.idl, keyed by the source robot), a keep-last writer and
// reader (reliable by default; DdsOptions), volatile durability. Receive() takes whatever arrived
// without blocking, validates every sample (a peer may send anything) and returns only frames for
// this robot or broadcast; own frames (same participant or another process with our id) are
// counted.
#include <dds/dds.h>

#include <atomic>
#include <cctype>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "dds_domains.hpp"
#include "draco/middleware/transport.hpp"
#include "link.h"

namespace draco::middleware {
namespace {

constexpr std::uint32_t kTakeBatch = 32;
constexpr int kMaxHistoryDepth = 100000;

std::string Where(const DdsOptions& options) {
  return "domain " + std::to_string(options.domain_id) + ", topic '" + DdsTopicName(options) +
         "', config " +
         (options.config_file.empty() ? std::string("default ($CYCLONEDDS_URI or built-in)")
                                      : "'" + options.config_file + "'");
}

[[noreturn]] void Fail(const std::string& what, dds_return_t rc, const DdsOptions& options) {
  throw std::runtime_error("dds: " + what + " failed: " + dds_strretcode(rc) + " (" +
                           Where(options) + ")");
}

struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};
struct ListenerDeleter {
  void operator()(dds_listener_t* listener) const { dds_delete_listener(listener); }
};

class DdsTransport final : public Transport {
 public:
  explicit DdsTransport(const DdsOptions& options) : options_(options) {
    ValidateDdsOptions(options);
    Domains::Get().Acquire(options_.domain_id, options_.config_file, DomainUse::kTeamLink,
                           Where(options_));
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
    TransportCounters c = counters_;
    c.peers_lost = peers_lost_.load();
    return c;
  }

 private:
  void Start() {
    participant_ =
        dds_create_participant(static_cast<dds_domainid_t>(options_.domain_id), nullptr, nullptr);
    if (participant_ < 0) Fail("dds_create_participant", participant_, options_);
    std::unique_ptr<dds_qos_t, QosDeleter> qos(dds_create_qos());
    dds_qset_reliability(qos.get(),
                         options_.reliability == DdsReliability::kReliable
                             ? DDS_RELIABILITY_RELIABLE
                             : DDS_RELIABILITY_BEST_EFFORT,
                         DDS_MSECS(100));
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, options_.history_depth);
    dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
    const std::string name = DdsTopicName(options_);
    const dds_entity_t topic = dds_create_topic(participant_, &draco_link_LinkFrame_desc,
                                                name.c_str(), qos.get(), nullptr);
    if (topic < 0) Fail("dds_create_topic '" + name + "'", topic, options_);
    // The reader requests no liveliness (infinite lease: it matches writers with any lease)
    // and counts the writers that stop being alive.
    std::unique_ptr<dds_listener_t, ListenerDeleter> listener(dds_create_listener(this));
    dds_lset_liveliness_changed(listener.get(), &DdsTransport::OnLivelinessChanged);
    reader_ = dds_create_reader(participant_, topic, qos.get(), listener.get());
    if (reader_ < 0) Fail("dds_create_reader", reader_, options_);
    std::unique_ptr<dds_qos_t, QosDeleter> writer_qos(dds_create_qos());
    dds_copy_qos(writer_qos.get(), qos.get());
    if (options_.liveliness_lease_s > 0.0) {
      dds_qset_liveliness(writer_qos.get(), DDS_LIVELINESS_AUTOMATIC,
                          static_cast<dds_duration_t>(options_.liveliness_lease_s * 1e9));
    }
    writer_ = dds_create_writer(participant_, topic, writer_qos.get(), nullptr);
    if (writer_ < 0) Fail("dds_create_writer", writer_, options_);
  }

  void Stop() {
    if (participant_ > 0) dds_delete(participant_);  // deletes topic, reader, writer
    participant_ = 0;
    Domains::Get().Release(options_.domain_id);
  }

  // Cyclone's listener thread: a matched writer stopped being alive (deleted, or its lease
  // lapsed). Our own writer, deleted with the participant, is counted too but no longer read.
  static void OnLivelinessChanged(dds_entity_t, const dds_liveliness_changed_status_t status,
                                  void* arg) {
    if (status.alive_count_change < 0) {
      static_cast<DdsTransport*>(arg)->peers_lost_ +=
          static_cast<std::uint64_t>(-static_cast<std::int64_t>(status.alive_count_change));
    }
  }

  DdsOptions options_;
  std::atomic<std::uint64_t> peers_lost_{0};
  dds_entity_t participant_ = 0;
  dds_entity_t reader_ = 0;
  dds_entity_t writer_ = 0;
  mutable std::mutex mutex_;
  TransportCounters counters_;
};

}  // namespace

DdsReliability ParseDdsReliability(const std::string& text) {
  if (text == "reliable") return DdsReliability::kReliable;
  if (text == "best_effort") return DdsReliability::kBestEffort;
  throw std::invalid_argument("dds reliability '" + text + "': expected reliable or best_effort");
}

const char* DdsReliabilityName(DdsReliability reliability) {
  return reliability == DdsReliability::kReliable ? "reliable" : "best_effort";
}

std::string DdsTopicName(const DdsOptions& options) { return options.topic_prefix + "draco_link"; }

void ValidateDdsOptions(const DdsOptions& o) {
  if (o.domain_id < 0 || o.domain_id > 232) {
    throw std::invalid_argument("dds domain_id " + std::to_string(o.domain_id) +
                                ": expected 0 to 232");
  }
  for (const char c : o.topic_prefix) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') {
      throw std::invalid_argument("dds topic_prefix '" + o.topic_prefix +
                                  "': expected letters, digits and '_' only");
    }
  }
  if (o.reliability != DdsReliability::kReliable && o.reliability != DdsReliability::kBestEffort) {
    throw std::invalid_argument("dds reliability: expected reliable or best_effort");
  }
  if (o.history_depth < 1 || o.history_depth > kMaxHistoryDepth) {
    throw std::invalid_argument("dds history_depth " + std::to_string(o.history_depth) +
                                ": expected 1 to " + std::to_string(kMaxHistoryDepth));
  }
  if (!std::isfinite(o.liveliness_lease_s) || o.liveliness_lease_s < 0.0) {
    throw std::invalid_argument("dds liveliness_lease_s " + std::to_string(o.liveliness_lease_s) +
                                ": expected 0 (no lease) or a positive number of seconds");
  }
}

std::unique_ptr<Transport> MakeDdsTransport(const DdsOptions& options) {
  return std::make_unique<DdsTransport>(options);
}

}  // namespace draco::middleware
