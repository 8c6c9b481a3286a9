// Components used only by the runtime's tests.
#pragma once

#include <atomic>
#include <string>
#include <vector>

namespace draco::graph::test {

// Shared observation points for the test components (reset by each test).
struct Probe {
  std::atomic<int> concurrent{0};
  std::atomic<int> max_concurrent{0};
  std::atomic<int> stops{0};
  std::atomic<int> processed{0};
  std::atomic<bool> stop_flag{false};
};
Probe& GetProbe();

}  // namespace draco::graph::test
