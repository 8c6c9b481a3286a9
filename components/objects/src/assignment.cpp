// Shortest-augmenting-path linear assignment (see assignment.hpp).
#include "draco/objects/assignment.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace draco::objects {
namespace {

// n <= m. c(i, j) for i in [0, n), j in [0, m). Returns the column of every row.
template <class Cost>
std::vector<int> Augment(int n, int m, Cost c) {
  const double inf = std::numeric_limits<double>::infinity();
  // Potentials u (rows), v (columns); column 0 is a virtual start column, rows and columns
  // are 1-based inside.
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0), shortest(m + 1);
  std::vector<int> row_of(m + 1, 0), previous(m + 1, 0);
  std::vector<char> visited(m + 1);
  for (int row = 1; row <= n; ++row) {
    // Dijkstra on reduced costs from the free row until a free column is reached.
    row_of[0] = row;
    int col = 0;
    std::fill(shortest.begin(), shortest.end(), inf);
    std::fill(visited.begin(), visited.end(), 0);
    do {
      visited[col] = 1;
      const int i = row_of[col];
      double delta = inf;
      int next = 0;
      for (int j = 1; j <= m; ++j) {
        if (visited[j]) continue;
        const double reduced = c(i - 1, j - 1) - u[i] - v[j];
        if (reduced < shortest[j]) {
          shortest[j] = reduced;
          previous[j] = col;
        }
        if (shortest[j] < delta) {
          delta = shortest[j];
          next = j;
        }
      }
      // Keep reduced costs non-negative on the tree; shorten the labels of the others.
      for (int j = 0; j <= m; ++j) {
        if (visited[j]) {
          u[row_of[j]] += delta;
          v[j] -= delta;
        } else {
          shortest[j] -= delta;
        }
      }
      col = next;
    } while (row_of[col] != 0);
    // Flip the alternating path back to the start.
    while (col != 0) {
      const int before = previous[col];
      row_of[col] = row_of[before];
      col = before;
    }
  }
  std::vector<int> col_of_row(n, -1);
  for (int j = 1; j <= m; ++j) {
    if (row_of[j] > 0) col_of_row[row_of[j] - 1] = j - 1;
  }
  return col_of_row;
}

}  // namespace

std::vector<int> SolveAssignment(const std::vector<double>& cost, int rows, int cols) {
  if (rows < 0 || cols < 0 || cost.size() != static_cast<std::size_t>(rows) * cols) {
    throw std::invalid_argument("SolveAssignment: cost must be rows x cols");
  }
  if (rows == 0 || cols == 0) return std::vector<int>(rows, -1);
  if (rows <= cols) {
    return Augment(rows, cols, [&](int i, int j) { return cost[std::size_t(i) * cols + j]; });
  }
  // More rows than columns: assign every column on the transpose.
  const std::vector<int> row_of_col =
      Augment(cols, rows, [&](int j, int i) { return cost[std::size_t(i) * cols + j]; });
  std::vector<int> col_of_row(rows, -1);
  for (int j = 0; j < cols; ++j) col_of_row[row_of_col[j]] = j;
  return col_of_row;
}

}  // namespace draco::objects
