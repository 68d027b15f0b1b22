// shearzone/profile/width_input.hpp: what the width needs, from a profile read back
// from its CSV (io/profile_csv.hpp) and the per-pair means beside it.
#pragma once

#include "shearzone/io/profile_csv.hpp"
#include "shearzone/profile/width.hpp"

namespace shearzone::profile {

/// The width input of one profile file and its groups file (io::profile_groups_path):
/// the bins' values, the lock-in columns and harmonics, the PIV's bounds from the header
/// (absent: 0), R (the header's R_m, else the last bin's outer edge) and, unless the
/// header's grouping is none, every pair's means per bin. InputError names the file (and
/// line) of a header value out of range, a missing groups file or a radius that is not
/// a bin.
WidthInput width_input(const io::ProfileCsv& p);

}  // namespace shearzone::profile
