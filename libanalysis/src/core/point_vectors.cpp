#include "shearzone/core/point_vectors.hpp"

namespace shearzone::core {

void PointVectors::clear() {
  x_px.clear();
  y_px.clear();
  u_px.clear();
  v_px.clear();
  flag.clear();
}

void PointVectors::push_back(double x, double y, double u, double v, VectorFlag f) {
  x_px.push_back(x);
  y_px.push_back(y);
  u_px.push_back(u);
  v_px.push_back(v);
  flag.push_back(f);
}

void to_points(const VectorField& field, PointVectors& out) {
  out.clear();
  for (std::size_t i = 0; i < field.ny(); ++i)
    for (std::size_t j = 0; j < field.nx(); ++j) {
      const std::size_t k = field.index(i, j);
      out.push_back(field.x_px[j], field.y_px[i], field.u_px[k], field.v_px[k], field.flag[k]);
    }
}

}  // namespace shearzone::core
