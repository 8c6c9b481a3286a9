#include "run_info.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include "app_version.hpp"

namespace draco::app {
namespace fs = std::filesystem;

namespace {

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string Executable() {
  std::error_code ec;
  const auto p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : p.string();
}

}  // namespace

void RunInfo::AddFile(const std::string& role, const fs::path& path) {
  std::error_code ec;
  const fs::path absolute = fs::absolute(path, ec);
  files.emplace_back(role, (ec ? path : absolute).lexically_normal().string());
}

RunInfo MakeRunInfo(const std::string& app, int argc, const char* const* argv) {
  RunInfo info;
  info.app = app;
  for (int i = 0; i < argc; ++i) info.argv.emplace_back(argv[i]);
  std::error_code ec;
  info.working_directory = fs::current_path(ec).string();
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &utc);
  info.started_utc = stamp;
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) == 0) info.host = host;
  for (const char* name :
       {"DRACO_DATA_DIR", "XDG_CONFIG_HOME", "CYCLONEDDS_URI", "DRACO_DDS_PEERS"}) {
    if (const char* value = std::getenv(name)) info.environment.emplace_back(name, value);
  }
  return info;
}

std::string ShellQuote(const std::vector<std::string>& argv) {
  std::string out;
  for (const auto& a : argv) {
    if (!out.empty()) out += ' ';
    const bool plain = !a.empty() && a.find_first_not_of(
                                         "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                         "0123456789_-+=.,/:@%") == std::string::npos;
    if (plain) {
      out += a;
      continue;
    }
    out += '\'';
    for (const char c : a) {
      if (c == '\'') {
        out += "'\\''";
      } else {
        out += c;
      }
    }
    out += '\'';
  }
  return out;
}

std::string RunInfoJson(const RunInfo& info) {
  std::string j = "{\n";
  auto field = [&](const char* key, const std::string& value) {
    j += "  " + JsonString(key) + ": " + JsonString(value) + ",\n";
  };
  field("app", info.app);
  field("version", Version());
  field("project_version", ProjectVersion());
  field("git_describe", GitDescribe());
  field("command_line", ShellQuote(info.argv));
  j += "  \"argv\": [";
  for (std::size_t i = 0; i < info.argv.size(); ++i) {
    j += (i ? ", " : "") + JsonString(info.argv[i]);
  }
  j += "],\n";
  field("executable", Executable());
  field("working_directory", info.working_directory);
  field("started_utc", info.started_utc);
  field("host", info.host);
  auto object = [&](const char* key, const std::vector<std::pair<std::string, std::string>>& kv,
                    bool last) {
    j += "  " + JsonString(key) + ": {";
    for (std::size_t i = 0; i < kv.size(); ++i) {
      j += (i ? ",\n    " : "\n    ") + JsonString(kv[i].first) + ": " + JsonString(kv[i].second);
    }
    j += kv.empty() ? "}" : "\n  }";
    j += last ? "\n" : ",\n";
  };
  object("environment", info.environment, false);
  object("files", info.files, true);
  return j + "}\n";
}

fs::path WriteRunInfo(const fs::path& dir, const RunInfo& info, const std::string& prefix) {
  const fs::path path = dir / (prefix + "run_info.json");
  const fs::path tmp = dir / (prefix + "run_info.json.partial");
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << RunInfoJson(info);
    out.close();
    if (!out) throw std::runtime_error(tmp.string() + ": cannot write the run information");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw std::runtime_error(path.string() + ": cannot write the run information");
  }
  return path;
}

}  // namespace draco::app
