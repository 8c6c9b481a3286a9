#include "test_bags.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>

namespace draco::rosbag::testbags {
namespace {

namespace fs = std::filesystem;

class BagDir {
 public:
  BagDir() : dir_(fs::path(DRACO_ROSBAG_WORK_DIR) / ("bags-" + std::to_string(::getpid()))) {
    fs::remove_all(dir_);
    const std::string command =
        std::string(DRACO_ROSBAG_PYTHON) + " " + DRACO_ROSBAG_WRITER + " " + dir_.string();
    if (std::system(command.c_str()) != 0) throw std::runtime_error("failed: " + command);
  }
  ~BagDir() {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
};

}  // namespace

std::string Path(const std::string& name) {
  static const BagDir bags;
  return (bags.dir() / name).string();
}

}  // namespace draco::rosbag::testbags
