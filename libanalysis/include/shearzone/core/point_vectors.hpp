// shearzone/core/point_vectors.hpp: displacements at scattered points: the tracked
// beads of a pair (one each), or the nodes of a grid (core/vector_field.hpp) listed one
// by one. The profile stage bins either by radius alike.
//
// Conventions as core/vector_field.hpp: x right, y down, pixel (row i, column j)
// centred at (j, i); u_px, v_px the displacement from frame a to frame b in px; flags
// say what each one is, and a value that is not measured (masked, invalid) is never read.
#pragma once

#include <cstddef>
#include <vector>

#include "shearzone/core/vector_field.hpp"

namespace shearzone::core {

struct PointVectors {
  std::vector<double> x_px, y_px;  ///< where each displacement belongs, px
  std::vector<double> u_px, v_px;  ///< displacement a -> b, px per pair
  std::vector<VectorFlag> flag;

  std::size_t size() const { return x_px.size(); }
  void clear();
  void push_back(double x, double y, double u, double v, VectorFlag f);
};

/// The grid's nodes as points, row by row (y outer, x inner), flags kept.
void to_points(const VectorField& field, PointVectors& out);

}  // namespace shearzone::core
