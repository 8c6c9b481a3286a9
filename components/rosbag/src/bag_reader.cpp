#include "draco/rosbag/bag_reader.hpp"

#include <fstream>
#include <map>
#include <set>
#include <utility>

#include "bag_file.hpp"

namespace draco::rosbag {
namespace {

enum class Role { kSonar, kDvl, kImu, kDepth, kGroundTruth };

const char* RoleName(Role role) {
  switch (role) {
    case Role::kSonar:
      return "sonar";
    case Role::kDvl:
      return "DVL";
    case Role::kImu:
      return "IMU";
    case Role::kDepth:
      return "depth";
    case Role::kGroundTruth:
      return "ground truth";
  }
  return "";
}

// Fields a connection's definition must have to be read in a role.
std::vector<std::string> RequiredFields(Role role) {
  switch (role) {
    case Role::kSonar:
      return {"bearings", "range_resolution", "ping.data"};
    case Role::kDvl:
      return {"velocity.x", "velocity.y", "velocity.z"};
    case Role::kImu:
      return {"orientation.x", "orientation.y", "orientation.z", "orientation.w"};
    case Role::kDepth:
      return {"depth"};
    case Role::kGroundTruth:
      return {"pose.position.x", "pose.orientation.w"};
  }
  return {};
}

}  // namespace

struct BagReader::Impl {
  std::string path;
  Options options;
  std::unique_ptr<internal::BagFile> bag;
  std::vector<internal::BagIndexEntry> entries;  // the selected topics' messages, in time order
  std::size_t next = 0;
  std::map<std::uint32_t, Role> roles;            // by connection
  std::map<std::string, std::size_t> next_index;  // per topic
  // Parsed definitions by connection id (each connection carries its own definition).
  std::map<std::uint32_t, std::shared_ptr<const MessageDefinition>> definitions;
  std::int64_t start_ns = 0;  // mission times are differences of integer nanoseconds
  double start_s = 0.0;
  double end_s = 0.0;
  std::string sonar_topic;
  std::string fatal;  // set after a file-level read error: Next() keeps failing with it

  std::string Where(const std::string& topic, std::size_t index) const {
    return path + ": topic " + topic + ", message " + std::to_string(index);
  }
};

BagReader::BagReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
BagReader::BagReader(BagReader&&) noexcept = default;
BagReader& BagReader::operator=(BagReader&&) noexcept = default;
BagReader::~BagReader() = default;

BagReader BagReader::Open(const std::string& path, Options options) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  impl->options = std::move(options);
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw BagError(path + ": cannot open file (missing or unreadable)");
  }
  try {
    impl->bag = std::make_unique<internal::BagFile>(path);
  } catch (const internal::BagFileError& e) {
    throw BagError(path + ": not a readable ROS 1 bag (" + e.what() + ")");
  }
  const internal::BagFile& bag = *impl->bag;
  const Options& opt = impl->options;
  if (!bag.empty()) {
    impl->start_ns = bag.first().Nanoseconds();
    impl->start_s = bag.first().Seconds();
    impl->end_s = bag.last().Seconds();
  }
  std::set<std::string> present;
  for (const auto& c : bag.connections()) present.insert(c.topic);
  std::map<std::string, Role> roles;  // by topic
  for (const auto& topic : opt.sonar_topics) {
    if (present.count(topic) != 0) {
      impl->sonar_topic = topic;
      break;
    }
  }
  if (!impl->sonar_topic.empty()) roles[impl->sonar_topic] = Role::kSonar;
  const std::pair<const std::string*, Role> others[] = {
      {&opt.dvl_topic, Role::kDvl},
      {&opt.imu_topic, Role::kImu},
      {&opt.depth_topic, Role::kDepth},
      {&opt.ground_truth_topic, Role::kGroundTruth}};
  for (const auto& [topic, role] : others) {
    if (!topic->empty() && present.count(*topic) != 0) {
      if (roles.count(*topic) != 0) {
        throw BagError(path + ": topic " + *topic + " is configured for two streams");
      }
      roles[*topic] = role;
    }
  }
  // Parse and check every selected connection's definition up front.
  std::set<std::uint32_t> selected;
  for (const auto& c : bag.connections()) {
    auto role = roles.find(c.topic);
    if (role == roles.end()) continue;
    std::shared_ptr<const MessageDefinition> def;
    try {
      def = std::make_shared<const MessageDefinition>(
          MessageDefinition::Parse(c.datatype, c.definition));
    } catch (const DecodeError& e) {
      throw BagError(path + ": topic " + c.topic + " (" + c.datatype + "): " + e.what());
    }
    for (const auto& field : RequiredFields(role->second)) {
      if (!def->HasField(field)) {
        throw BagError(path + ": topic " + c.topic + " has type " + c.datatype +
                       ", whose definition lacks field '" + field + "' needed for " +
                       RoleName(role->second) + " messages");
      }
    }
    impl->definitions[c.id] = std::move(def);
    impl->roles[c.id] = role->second;
    selected.insert(c.id);
  }
  impl->entries = bag.Entries(selected);
  return BagReader(std::move(impl));
}

std::optional<Record> BagReader::Next() {
  Impl& s = *impl_;
  if (!s.fatal.empty()) throw BagError(s.fatal);
  if (s.next >= s.entries.size()) return std::nullopt;

  const internal::BagIndexEntry& entry = s.entries[s.next++];
  const internal::BagConnection& connection = *s.bag->FindConnection(entry.connection);
  Record record;
  record.topic = connection.topic;
  record.index = s.next_index[record.topic]++;
  record.receipt_time_s = entry.Seconds();
  const std::int64_t receipt_ns = entry.Nanoseconds();
  const Role role = s.roles.at(entry.connection);
  const MessageDefinition& def = *s.definitions.at(entry.connection);
  internal::BagFile::Message bytes;
  try {
    bytes = s.bag->Read(entry);
  } catch (const internal::BagFileError& e) {
    s.fatal = s.path + ": read error at topic " + record.topic + ", message " +
              std::to_string(record.index) + " (" + e.what() +
              "); the file is truncated or corrupt";
    throw BagError(s.fatal);
  }

  try {
    RosValue value = def.Decode(bytes.data, bytes.size);
    const RosValue* stamp = value.Find("header.stamp");
    const RosTime* stamp_time = stamp ? stamp->AsTime() : nullptr;
    std::int64_t ns = receipt_ns;
    record.stamp_time_s = record.receipt_time_s;
    if (s.options.use_header_stamp && stamp_time && (stamp_time->sec > 0 || stamp_time->nsec > 0)) {
      ns = stamp_time->sec * 1000000000 + stamp_time->nsec;
      record.stamp_time_s = stamp_time->Seconds();
    }
    const double t = static_cast<double>(ns - s.start_ns) * 1e-9;
    const ConvertOptions& c = s.options.convert;
    switch (role) {
      case Role::kSonar:
        record.message = ToSonarPing(value, t, c);
        break;
      case Role::kDvl:
        record.message = ToDvlVelocity(value, t, c);
        break;
      case Role::kImu:
        record.message = ToAhrs(value, t, c);
        break;
      case Role::kDepth:
        record.message = ToDepth(value, t);
        break;
      case Role::kGroundTruth:
        record.message = ToGroundTruthPose(value, t, c);
        break;
    }
  } catch (const DecodeError& e) {
    throw BagError(s.Where(record.topic, record.index) + " (" + def.root_type() + "): " + e.what(),
                   /*bad_message=*/true);
  }
  return record;
}

const std::string& BagReader::path() const { return impl_->path; }
double BagReader::start_time_s() const { return impl_->start_s; }
double BagReader::end_time_s() const { return impl_->end_s; }
const std::string& BagReader::sonar_topic() const { return impl_->sonar_topic; }
std::size_t BagReader::selected_message_count() const { return impl_->entries.size(); }

std::vector<TopicInfo> BagReader::Topics() const {
  std::map<std::string, TopicInfo> by_topic;
  for (const auto& c : impl_->bag->connections()) {
    TopicInfo& info = by_topic[c.topic];
    info.topic = c.topic;
    info.datatype = c.datatype;
    info.md5sum = c.md5sum;
    info.message_count += impl_->bag->MessageCount(c.id);
  }
  std::vector<TopicInfo> out;
  for (auto& [topic, info] : by_topic) out.push_back(std::move(info));
  return out;
}

}  // namespace draco::rosbag
