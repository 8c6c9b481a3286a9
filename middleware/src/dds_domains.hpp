// Cyclone DDS domains opened by this process, shared by every participant in it (internal to
// middleware/). Cyclone allows one dds_create_domain per domain id and process, so the team
// link's transports and the ROS 2 monitor ask here. A domain is opened for one use: the team
// link's domain is never also the monitor's, so monitoring traffic cannot reach the link.
#pragma once

#include <dds/dds.h>

#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>

namespace draco::middleware {

enum class DomainUse { kTeamLink, kRos2Monitor };

inline const char* DomainUseName(DomainUse use) {
  return use == DomainUse::kTeamLink ? "the team link" : "the ROS 2 monitor";
}

inline std::string ReadDdsConfig(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  if (in) text << in.rdbuf();
  if (!in || text.str().empty()) {
    throw std::runtime_error("dds: cannot read the Cyclone DDS configuration file '" + path + "'");
  }
  return text.str();
}

class Domains {
 public:
  static Domains& Get() {
    static Domains domains;
    return domains;
  }

  // Opens domain_id with the configuration file (empty: $CYCLONEDDS_URI or Cyclone's
  // defaults) or joins it when this process has it open for the same use and configuration.
  // Throws std::runtime_error naming `where` otherwise.
  void Acquire(int domain_id, const std::string& config_file, DomainUse use,
               const std::string& where) {
    std::string config = config_file.empty() ? "" : ReadDdsConfig(config_file);
    std::lock_guard lock(mutex_);
    auto it = open_.find(domain_id);
    if (it != open_.end()) {
      if (it->second.use != use) {
        throw std::runtime_error("dds: domain " + std::to_string(domain_id) + " is " +
                                 DomainUseName(it->second.use) + "'s; " + DomainUseName(use) +
                                 " needs a domain of its own (" + where + ")");
      }
      if (it->second.config != config) {
        throw std::runtime_error("dds: domain " + std::to_string(domain_id) +
                                 " is already open in this process with another configuration (" +
                                 where + ")");
      }
      ++it->second.users;
      return;
    }
    dds_entity_t domain = 0;
    if (!config.empty()) {
      domain = dds_create_domain(static_cast<dds_domainid_t>(domain_id), config.c_str());
      if (domain < 0) {
        throw std::runtime_error(std::string("dds: dds_create_domain failed: ") +
                                 dds_strretcode(domain) + " (" + where + ")");
      }
    }
    open_.emplace(domain_id, Open{domain, std::move(config), use, 1});
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
    DomainUse use;
    int users;
  };
  std::mutex mutex_;
  std::map<int, Open> open_;
};

}  // namespace draco::middleware
