#include "draco/rosbag/bag_reader.hpp"

#include <fstream>
#include <map>
#include <sstream>
#include <utility>

#include <console_bridge/console.h>
#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <rosbag/query.h>
#include <rosbag/view.h>

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

double Seconds(const ros::Time& t) { return t.toSec(); }
std::int64_t Nanoseconds(const ros::Time& t) { return static_cast<std::int64_t>(t.toNSec()); }

}  // namespace

struct BagReader::Impl {
  std::string path;
  Options options;
  ::rosbag::Bag bag;
  std::unique_ptr<::rosbag::View> view;
  ::rosbag::View::iterator it;
  std::map<std::string, Role> roles;
  std::map<std::string, std::size_t> next_index;  // per topic
  // Parsed definitions by connection id (each connection carries its own definition).
  std::map<std::uint32_t, std::shared_ptr<const MessageDefinition>> definitions;
  std::vector<std::uint8_t> buffer;
  std::int64_t start_ns = 0;  // mission times are differences of integer nanoseconds
  double start_s = 0.0;
  double end_s = 0.0;
  std::string sonar_topic;
  std::size_t selected = 0;
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
  // rosbag logs through console_bridge; errors reach the caller as exceptions instead.
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  try {
    impl->bag.open(path, ::rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw BagError(path + ": not a readable ROS 1 bag (" + e.what() + ")");
  }

  const Options& opt = impl->options;
  try {
    ::rosbag::View all(impl->bag);
    std::map<std::string, bool> present;
    for (const auto* c : all.getConnections()) present[c->topic] = true;
    if (all.size() > 0) {
      impl->start_ns = Nanoseconds(all.getBeginTime());
      impl->start_s = Seconds(all.getBeginTime());
      impl->end_s = Seconds(all.getEndTime());
    }
    for (const auto& topic : opt.sonar_topics) {
      if (present.count(topic) != 0) {
        impl->sonar_topic = topic;
        break;
      }
    }
    if (!impl->sonar_topic.empty()) impl->roles[impl->sonar_topic] = Role::kSonar;
    const std::pair<const std::string*, Role> others[] = {
        {&opt.dvl_topic, Role::kDvl},
        {&opt.imu_topic, Role::kImu},
        {&opt.depth_topic, Role::kDepth},
        {&opt.ground_truth_topic, Role::kGroundTruth}};
    for (const auto& [topic, role] : others) {
      if (!topic->empty() && present.count(*topic) != 0) {
        if (impl->roles.count(*topic) != 0) {
          throw BagError(path + ": topic " + *topic + " is configured for two streams");
        }
        impl->roles[*topic] = role;
      }
    }
    std::vector<std::string> topics;
    for (const auto& [topic, role] : impl->roles) topics.push_back(topic);
    if (topics.empty()) {
      impl->view = std::make_unique<::rosbag::View>();
    } else {
      impl->view = std::make_unique<::rosbag::View>(impl->bag, ::rosbag::TopicQuery(topics));
    }
    // Parse and check every selected connection's definition up front.
    for (const auto* c : impl->view->getConnections()) {
      Role role = impl->roles.at(c->topic);
      std::shared_ptr<const MessageDefinition> def;
      try {
        def = std::make_shared<const MessageDefinition>(
            MessageDefinition::Parse(c->datatype, c->msg_def));
      } catch (const DecodeError& e) {
        throw BagError(path + ": topic " + c->topic + " (" + c->datatype + "): " + e.what());
      }
      for (const auto& field : RequiredFields(role)) {
        if (!def->HasField(field)) {
          throw BagError(path + ": topic " + c->topic + " has type " + c->datatype +
                         ", whose definition lacks field '" + field + "' needed for " +
                         RoleName(role) + " messages");
        }
      }
      impl->definitions[c->id] = std::move(def);
    }
    impl->selected = impl->view->size();
    impl->it = impl->view->begin();
  } catch (const BagError&) {
    throw;
  } catch (const std::exception& e) {
    throw BagError(path + ": cannot read the bag index (" + e.what() + ")");
  }
  return BagReader(std::move(impl));
}

std::optional<Record> BagReader::Next() {
  Impl& s = *impl_;
  if (!s.fatal.empty()) throw BagError(s.fatal);
  if (!s.view || s.it == s.view->end()) return std::nullopt;

  Record record;
  std::int64_t receipt_ns = 0;
  std::shared_ptr<const MessageDefinition> def;
  Role role = Role::kSonar;
  try {
    const ::rosbag::MessageInstance& m = *s.it;
    record.topic = m.getTopic();
    record.index = s.next_index[record.topic]++;
    record.receipt_time_s = Seconds(m.getTime());
    receipt_ns = Nanoseconds(m.getTime());
    role = s.roles.at(record.topic);
    // The definition by connection: the datatype, md5 and text identify it.
    const std::string key_topic = record.topic;
    for (const auto* c : s.view->getConnections()) {
      if (c->topic == key_topic && c->datatype == m.getDataType() && c->md5sum == m.getMD5Sum() &&
          c->msg_def == m.getMessageDefinition()) {
        def = s.definitions.at(c->id);
        break;
      }
    }
    s.buffer.resize(m.size());
    ros::serialization::OStream stream(s.buffer.data(), static_cast<std::uint32_t>(m.size()));
    m.write(stream);
    ++s.it;
  } catch (const std::exception& e) {
    s.fatal = s.path + ": read error" +
              (record.topic.empty()
                   ? std::string()
                   : " at topic " + record.topic + ", message " + std::to_string(record.index)) +
              " (" + e.what() + "); the file is truncated or corrupt";
    throw BagError(s.fatal);
  }
  if (!def) throw BagError(s.Where(record.topic, record.index) + ": unknown connection", true);

  try {
    RosValue value = def->Decode(s.buffer.data(), s.buffer.size());
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
    throw BagError(s.Where(record.topic, record.index) + " (" + def->root_type() + "): " + e.what(),
                   /*bad_message=*/true);
  }
  return record;
}

const std::string& BagReader::path() const { return impl_->path; }
double BagReader::start_time_s() const { return impl_->start_s; }
double BagReader::end_time_s() const { return impl_->end_s; }
const std::string& BagReader::sonar_topic() const { return impl_->sonar_topic; }
std::size_t BagReader::selected_message_count() const { return impl_->selected; }

std::vector<TopicInfo> BagReader::Topics() const {
  std::vector<TopicInfo> out;
  try {
    ::rosbag::View all(impl_->bag);
    std::map<std::string, TopicInfo> by_topic;
    for (const auto* c : all.getConnections()) {
      TopicInfo& info = by_topic[c->topic];
      info.topic = c->topic;
      info.datatype = c->datatype;
      info.md5sum = c->md5sum;
    }
    for (auto& [topic, info] : by_topic) {
      info.message_count = ::rosbag::View(impl_->bag, ::rosbag::TopicQuery(topic)).size();
      out.push_back(info);
    }
  } catch (const std::exception& e) {
    throw BagError(impl_->path + ": cannot list topics (" + e.what() + ")");
  }
  return out;
}

}  // namespace draco::rosbag
