// shearzone/core/point_cells.hpp: points bucketed in square cells, for finding those
// near a place without comparing against all of them (bead tracks linked from pair to
// pair, synthetic beads matched to detections).
//
//     core::PointCells cells(x, y, radius);          // cells one radius wide
//     cells.near(px, py, [&](std::size_t i) { ... });  // every point in the 3 x 3 cells
//                                                      // around (px, py): all within radius
// Points come back cell by cell (rows of cells top to bottom, left to right), in the
// order they were given within a cell: the same every run.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

namespace shearzone::core {

class PointCells {
 public:
  PointCells(const std::vector<double>& x, const std::vector<double>& y, double cell) : cell_(cell) {
    for (std::size_t i = 0; i < x.size(); ++i) cells_[key(x[i], y[i])].push_back(i);
  }
  /// Calls f(i) for every point i in the cell of (x, y) and its eight neighbours: a
  /// superset of the points within one cell width.
  template <class F>
  void near(double x, double y, F f) const {
    const auto [cx, cy] = key(x, y);
    for (std::int64_t dy = -1; dy <= 1; ++dy)
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const auto it = cells_.find({cx + dx, cy + dy});
        if (it == cells_.end()) continue;
        for (std::size_t i : it->second) f(i);
      }
  }

 private:
  std::pair<std::int64_t, std::int64_t> key(double x, double y) const {
    return {static_cast<std::int64_t>(std::floor(x / cell_)), static_cast<std::int64_t>(std::floor(y / cell_))};
  }
  double cell_;
  std::map<std::pair<std::int64_t, std::int64_t>, std::vector<std::size_t>> cells_;
};

}  // namespace shearzone::core
