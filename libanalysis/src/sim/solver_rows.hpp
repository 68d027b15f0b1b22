// Private to the contact-dynamics engine (world.cpp): the solver's view of the bodies,
// its rows and the sweep bookkeeping. Not part of the installed API: world.hpp only
// forward-declares them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "shearzone/sim/world.hpp"
#include "sector.hpp"

namespace shearzone::sim::detail {

// Solver view of a body: one cache line (sentinel bodies after the real ones stand
// for the walls: zero velocity, zero inverse mass).
struct alignas(64) SolverBody {
  Vec3 v = Vec3::Zero();
  Vec3 w = Vec3::Zero();
  double inv_mass = 0.0;
  double inv_inertia = 0.0;
};
// Hot contact row, two cache lines; the freeze state sits in the first, so a skipped
// row costs one line. A wall row has i = a wall sentinel and ri = 0.
struct alignas(64) ContactRow {
  int i = 0, j = 0;
  std::int32_t frozen_until = 0;
  std::uint8_t quiet = 0;
  ContactStatus status = ContactStatus::kOpen;
  std::int8_t image = 0;   // periodic sector: 1 when j is seen as R x_j (a seam row)
  Vec3 n = Vec3::UnitZ();  // from i (or the wall) to j
  double bias = 0.0;       // gap / h
  double ri = 0.0, rj = 0.0;
  double inv_wn = 0.0, inv_wt = 0.0;
  double mu = 0.0;
  double pn = 0.0;
  Vec3 pt = Vec3::Zero();
};
// Cold contact data, parallel to contacts_.
struct ContactInfo {
  std::uint64_t key = 0;
  int i = -1, wall = -1;  // i = −1 for a wall row
  double gap = 0.0;
};
struct PreviousContact {
  std::uint64_t key = 0;
  double pn = 0.0;
  Vec3 pt = Vec3::Zero();
  ContactStatus status = ContactStatus::kOpen;
};
struct RopeRow {
  int i = 0, j = 0;
  double max_length = 0.0;
  Vec3 e = Vec3::UnitX();   // from i to j, in i's frame
  Vec3 ej = Vec3::UnitX();  // the same in j's frame (R^−image e; = e without a seam)
  double c = 0.0, bias = 0.0, wb = 0.0, lambda = 0.0;
  std::int32_t frozen_until = 0;
  std::uint8_t quiet = 0;
  std::int8_t image = 0;  // periodic sector: j seen from i as R^image x_j
};
struct AngleRow {
  int a = 0, b = 0, c = 0;
  double max_angle = 0.0, cos_max = 1.0;
  Vec3 ga = Vec3::Zero(), gb = Vec3::Zero(), gc = Vec3::Zero();  // ∂c/∂x, each in its body's frame
  double ca = 0.0, bias = 0.0, wa = 0.0, scale = 0.0, lambda = 0.0;
  std::int32_t frozen_until = 0;
  std::uint8_t quiet = 0;
  bool live = false;  // W_a above the straight-chain guard
  std::int8_t image_a = 0, image_c = 0;  // periodic sector: a and c seen from b as R^k x
};
// The impulse p of a contact row with normal n, lever arms ri and rj and seam image
// `image` applied to its two bodies: +p on j, -p on i, with their moments; a seam row's
// j side in j's frame. Shared by the warm start and the sweeps (the sweeps' hottest
// lines: always inlined, the row's fields passed by value).
[[gnu::always_inline]] inline void apply_row_impulse(SolverBody& bi, SolverBody& bj, int image, double ri, double rj,
                                                     const Vec3& n, const Vec3& p, const Sector& sec) {
  const Vec3 np = n.cross(p);
  if (image != 0) {
    bj.v += bj.inv_mass * sec.rot(p, -1);
    bj.w -= (bj.inv_inertia * rj) * sec.rot(np, -1);
  } else {
    bj.v += bj.inv_mass * p;
    bj.w -= (bj.inv_inertia * rj) * np;
  }
  bi.v -= bi.inv_mass * p;
  bi.w -= (bi.inv_inertia * ri) * np;
}
// Rows of one slab (or of the boundary between slabs), by index.
struct RowLists {
  std::vector<int> contacts, ropes, angles;
  void clear() {
    contacts.clear();
    ropes.clear();
    angles.clear();
  }
};
// Anderson acceleration of the sweep (Options::anderson_depth; world.cpp). The impulses
// of all rows form one vector: 4 entries per contact row (P_n, P_t), then one per rope
// row, one per angle row (by row index). Scratch: the last sweep's residual F = G − P_in
// and output G, and m columns of differences of consecutive F and G.
struct Anderson {
  int m = 0;               // depth (columns kept)
  std::size_t stride = 0;  // entries of one vector
  std::size_t ropes_at = 0, angles_at = 0;
  std::vector<double> buf;  // fprev, gprev, then dF[0..m), dG[0..m)
  int count = 0;            // columns held (slots 0 … count−1)
  int newest = -1;          // slot of the newest column
  int push = -1;            // slot the recording sweep writes (−1: none)
  bool have_prev = false;   // fprev/gprev hold the previous sweep's
  double best = 0.0;        // lowest residual since the last restart
  double best_step = 0.0;   // lowest residual of the step
  int since_best = 0;       // sweeps since best_step fell
  bool off = false;         // stalled: plain NLGS for the rest of the step
  double H[10][10] = {};    // Gram matrix of the columns, ΔFᵢᵀ D ΔFⱼ, by slot
  double gamma[10] = {};    // coefficients by slot
  std::vector<double> part;  // per part: 2m partial sums (new Gram row, ΔFᵀ D F)
  // Quiet rows (F = 0 and G = 0: zero impulse, unchanged) are skipped where all their
  // entries are zero already. zero_since: per row (contacts, ropes, angles), the
  // recording sweep (iter) since which it has been quiet, kNever when it was not quiet at
  // the last one. last_push: per slot, the sweep that last wrote it (0: not this step).
  static constexpr std::int32_t kNever = 0x7fffffff;
  std::vector<std::int32_t> zero_since;
  std::int32_t iter = 0;            // recording sweeps of this step
  std::int32_t last_push[10] = {};
  std::int32_t skip_below = 0;      // a quiet row with zero_since ≤ this needs no recording
  [[nodiscard]] double* vec(int k) { return buf.data() + static_cast<std::size_t>(k) * stride; }
  [[nodiscard]] double* fprev() { return vec(0); }
  [[nodiscard]] double* gprev() { return vec(1); }
  [[nodiscard]] double* dF(int slot) { return vec(2 + slot); }
  [[nodiscard]] double* dG(int slot) { return vec(2 + m + slot); }
};
struct SweepTotals {
  double dv2 = 0.0, wp2 = 0.0;
  std::int64_t updates = 0, active = 0, skipped = 0, changed = 0;
};

}  // namespace shearzone::sim::detail
