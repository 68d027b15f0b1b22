#include "shearzone/core/vector_field.hpp"

#include <algorithm>

namespace shearzone::core {

const char* flag_name(VectorFlag f) {
  switch (f) {
    case VectorFlag::kValid: return "valid";
    case VectorFlag::kReplaced: return "replaced";
    case VectorFlag::kMasked: return "masked";
    case VectorFlag::kInvalid: return "invalid";
  }
  return "?";
}

std::string flag_mapping() { return "0 valid, 1 replaced, 2 masked, 3 invalid"; }

void VectorField::resize_to_grid() {
  const std::size_t n = size();
  u_px.assign(n, 0.0f);
  v_px.assign(n, 0.0f);
  peak.assign(n, 0.0f);
  peak_ratio.assign(n, 0.0f);
  flag.assign(n, VectorFlag::kValid);
}

std::size_t VectorField::count(VectorFlag f) const {
  return static_cast<std::size_t>(std::count(flag.begin(), flag.end(), f));
}

}  // namespace shearzone::core
