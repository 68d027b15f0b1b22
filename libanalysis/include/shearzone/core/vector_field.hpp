// shearzone/core/vector_field.hpp: a displacement or velocity field on a regular grid.
//
// The PIV stage produces it, the simulator's probes will too, and the profile stage
// consumes it, so the analysis cannot tell an experiment from a simulation.
//
// Grid: x_px[j] (nx columns, increasing) and y_px[i] (ny rows, increasing), in the
// image convention (x right, y down, pixel (row i, column j) centred at (j, i)).
// Per-vector arrays are row-major [ny][nx]: element (i, j) at i * nx + j.
// u_px, v_px: displacement from frame A to frame B in px (or px per pair).
// Flags say what each vector is; no value is ever NaN.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace shearzone::core {

enum class VectorFlag : std::uint8_t {
  kValid = 0,     ///< measured and passed validation
  kReplaced = 1,  ///< failed validation; replaced by interpolation from valid neighbours
  kMasked = 2,    ///< inside a mask: not measured (u = v = 0)
  kInvalid = 3,   ///< could not be measured (no texture, no peak); value interpolated
};

/// "valid", "replaced", "masked", "invalid".
const char* flag_name(VectorFlag f);
/// The mapping as stored in HDF5 attributes: "0 valid, 1 replaced, 2 masked, 3 invalid".
std::string flag_mapping();

struct VectorField {
  std::vector<double> x_px;       ///< nx grid x coordinates, px
  std::vector<double> y_px;       ///< ny grid y coordinates, px
  std::vector<float> u_px;        ///< [ny * nx] x displacement, px
  std::vector<float> v_px;        ///< [ny * nx] y displacement, px (y down)
  std::vector<float> peak;        ///< [ny * nx] normalised correlation peak height (0..1)
  std::vector<float> peak_ratio;  ///< [ny * nx] first over second correlation peak (>= 1)
  std::vector<VectorFlag> flag;   ///< [ny * nx]

  std::size_t nx() const { return x_px.size(); }
  std::size_t ny() const { return y_px.size(); }
  std::size_t size() const { return x_px.size() * y_px.size(); }
  std::size_t index(std::size_t i, std::size_t j) const { return i * x_px.size() + j; }
  /// Allocates the per-vector arrays for the current grid (zeros, flag valid).
  void resize_to_grid();
  /// Number of vectors with flag f.
  std::size_t count(VectorFlag f) const;
};

}  // namespace shearzone::core
