// shearzone/piv/validate.hpp: vector validation and outlier replacement.
//
// Normalised median test (Westerweel & Scarano 2005, Exp. Fluids 39:1096): for each
// vector U_0 with neighbours U_j in a (2r+1)^2 box (masked and invalid vectors and
// U_0 itself excluded), with U_m the neighbours' median and r_m the median of
// |U_j - U_m|, the normalised residual is |U_0 - U_m| / (r_m + epsilon). It is
// computed for u and v; above `threshold` in either, the vector is an outlier.
// All vectors are tested against the same input (no sequential effects).
#pragma once

#include <vector>

#include "shearzone/core/vector_field.hpp"
#include "shearzone/piv/options.hpp"

namespace shearzone::piv {

/// Flags outliers among kValid vectors as kReplaced (values unchanged) using the
/// normalised median test, the global std filter and the displacement limit of
/// `options`. A valid vector with fewer than a quarter of its unmasked neighbours in
/// the 5x5 box valid (at least 4 unmasked) is isolated among failed windows, where a
/// chance match is more likely than a measurement: it becomes kInvalid.
/// Returns how many were flagged.
std::size_t flag_outliers(core::VectorField& field, const PivOptions& options);

/// Replaces the values of every vector whose flag is in `holes` by the mean of its
/// known 3x3 neighbours, growing inwards from the known vectors (Jacobi sweeps:
/// deterministic). Known vectors are those not in `holes` and not masked unless
/// masked vectors are holes themselves. Holes with no known vector anywhere get 0.
void fill_holes(core::VectorField& field, const std::vector<core::VectorFlag>& holes);

/// A replaced vector is an interpolation from its neighbours: it is kept (as
/// kReplaced) only where those neighbours were measured, i.e. when at least
/// `min_valid_fraction` of its in-grid, unmasked 3x3 neighbours (and at least 3) are
/// kValid. Inside a larger flagged region it becomes kInvalid. Returns how many were
/// demoted. (Measured on the OpenPIV tutorial pair before this rule: 57 % of the
/// replaced vectors in large flagged regions were > 1 px from openpiv's field.)
std::size_t demote_unsupported_replacements(core::VectorField& field, double min_valid_fraction = 0.6);

}  // namespace shearzone::piv
