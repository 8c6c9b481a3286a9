// Rectangular linear assignment: minimum-cost matching of every row (rows <= cols) or every
// column (cols < rows) by shortest augmenting paths with dual potentials (Jonker-Volgenant
// augmentation, as in Crouse 2016; O(n^2 m)).
#pragma once

#include <vector>

namespace draco::objects {

// cost: rows x cols, row-major, finite. Returns, per row, its column or -1 (only when
// rows > cols). Minimises the sum of the chosen costs over min(rows, cols) pairs.
std::vector<int> SolveAssignment(const std::vector<double>& cost, int rows, int cols);

}  // namespace draco::objects
