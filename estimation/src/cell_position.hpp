#pragma once
// The cell of the 4-D table grid that holds a point, for the float
// multilinear interpolations (FastInverter::predict4, SubspaceTable::predict).
#include <algorithm>
#include <array>

namespace chromo::estimation::detail {

struct CellPosition {
  int base[4];        // the cell's lowest node per axis (≤ nodes − 2)
  float fraction[4];  // position inside the cell per axis, in [0, 1]
};

// x: grid coordinates (NaN read as 0), clamped into the grid of `nodes`
// nodes per axis (each ≥ 2).
inline CellPosition cell_position(const float* x, const std::array<int, 4>& nodes) {
  CellPosition cell;
  for (int k = 0; k < 4; ++k) {
    const float xc = std::clamp(x[k] == x[k] ? x[k] : 0.0f, 0.0f, static_cast<float>(nodes[k] - 1));
    cell.base[k] = std::min(static_cast<int>(xc), nodes[k] - 2);
    cell.fraction[k] = xc - static_cast<float>(cell.base[k]);
  }
  return cell;
}

}  // namespace chromo::estimation::detail
