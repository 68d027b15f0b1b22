// The contact-dynamics engine: the sweeps, their stopping test, threads and Anderson
// acceleration (see shearzone/sim/world.hpp for the model).
#include "shearzone/sim/world.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <iterator>
#include <limits>
#include <thread>

#include <Eigen/Cholesky>
#include <omp.h>

#include "local_solve.hpp"
#include "solver_rows.hpp"
#include "world_internal.hpp"

namespace shearzone::sim {

namespace {

/// Centralised sense-counting barrier that spins (with a pause, then yielding) instead
/// of sleeping. The last thread to arrive bumps the generation (release); the others
/// wait for it (acquire), so every write before the barrier is seen after it.
class SpinBarrier {
 public:
  void reset(int threads) {
    threads_ = threads;
    count_.store(0, std::memory_order_relaxed);
  }
  void wait() {
    const int gen = generation_.load(std::memory_order_acquire);
    if (count_.fetch_add(1, std::memory_order_acq_rel) == threads_ - 1) {
      count_.store(0, std::memory_order_relaxed);
      generation_.fetch_add(1, std::memory_order_release);
      return;
    }
    for (int spins = 0; generation_.load(std::memory_order_acquire) == gen; ++spins) {
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();
#endif
      if (spins > 4096) std::this_thread::yield();
    }
  }

 private:
  std::atomic<int> count_{0};
  std::atomic<int> generation_{0};
  int threads_ = 1;
};

/// Coulomb's cone for P_n > 0: P_t kept inside it (sticking), else scaled back onto
/// |P_t| = μ P_n along itself (radial return, sliding). The sweep's local solve and the
/// projection of an Anderson extrapolation.
inline ContactStatus radial_return(Vec3& pt, double pn, double mu) {
  const double limit = mu * pn;
  const double p2 = pt.squaredNorm();
  if (p2 <= limit * limit) return ContactStatus::kSticking;
  pt *= limit / std::sqrt(p2);
  return ContactStatus::kSliding;
}

/// Freeze bookkeeping of a visit that left a zero-impulse row unchanged: frozen after
/// two quiet visits in a row.
template <class Row>
void note_quiet(Row& r, int sweep, int freeze_sweeps) {
  if (freeze_sweeps > 0 && ++r.quiet >= 2) r.frozen_until = sweep + freeze_sweeps;
}

}  // namespace

// One pass over a list of rows (contacts, ropes, angles; reversed when backward).
// `check`: solve only the frozen rows (the convergence check of "Freezing" in world.hpp);
// otherwise solve every row that is not frozen. `aa` (Anderson acceleration, recording
// sweeps only): every row of the list, visited or skipped, records its residual F (the
// change this sweep made) and output G, the new difference column and the partial dot
// products into `sums` (2m values: the new Gram row, ΔFᵀ D F).
void World::sweep_lists(const RowLists& lists, bool forward, int sweep, bool check, SweepTotals& out,
                        detail::Anderson* aa, double* sums) {
  SweepTotals t;  // local: the totals of the slabs share cache lines
  SolverBody* const B = body_.data();
  const int freeze = opt_.freeze_sweeps;
  const detail::Sector sec(opt_);
  ContactRow* const C = contacts_.data();
  RopeRow* const R = ropes_.data();
  AngleRow* const A = angles_.data();

  // Anderson bookkeeping: entries [at, at + n) of the impulse vector.
  const bool rec = aa != nullptr;
  const int m = rec ? aa->m : 0;
  double* const fprev = rec ? aa->fprev() : nullptr;
  double* const gprev = rec ? aa->gprev() : nullptr;
  double* const dfp = rec && aa->push >= 0 ? aa->dF(aa->push) : nullptr;
  double* const dgp = rec && aa->push >= 0 ? aa->dG(aa->push) : nullptr;
  const double* held[10];  // columns 0 … count−1 (the new one included)
  const int nh = rec && dfp ? aa->count : 0;
  for (int h = 0; h < nh; ++h) held[h] = aa->dF(h);
  double hsum[10] = {}, bsum[10] = {};  // local: `sums` may share cache lines with other parts
  std::int32_t* const zs = rec ? aa->zero_since.data() : nullptr;
  const std::int32_t quiet_below = rec ? aa->skip_below : 0;
  auto record = [&](std::size_t row, std::size_t at, int n, const double* f, const double* g, const double* w) {
    zs[row] = detail::Anderson::kNever;
    for (int e = 0; e < n; ++e) {
      const std::size_t i = at + static_cast<std::size_t>(e);
      if (dfp) {
        const double df = f[e] - fprev[i];
        dfp[i] = df;
        dgp[i] = g[e] - gprev[i];
        for (int h = 0; h < nh; ++h) {
          const double a = w[e] * held[h][i];
          hsum[h] += a * dfp[i];
          bsum[h] += a * f[e];
        }
      }
      fprev[i] = f[e];
      gprev[i] = g[e];
    }
  };
  // A row left at zero impulse (skipped while frozen, or open and staying open): F = 0,
  // G = 0. A row quiet since before the previous sweep and before the last write of the
  // slot this sweep overwrites (Anderson::skip_below) holds zeros in every vector entry
  // it owns already: nothing to read or write. Otherwise its F and G are recorded as
  // zeros (the weights matter only where the previous F or G was not zero).
  auto record_zero = [&](std::size_t row, std::size_t at, int n, auto&& weights) {
    if (zs[row] <= quiet_below) return;
    if (zs[row] == detail::Anderson::kNever) zs[row] = aa->iter;
    bool was_zero = true;
    for (int e = 0; e < n; ++e) was_zero = was_zero && fprev[at + e] == 0.0 && gprev[at + e] == 0.0;
    if (was_zero) {
      if (dfp)
        for (int e = 0; e < n; ++e) dfp[at + e] = dgp[at + e] = 0.0;
      return;
    }
    double w[4];
    weights(w);
    const double zero[4] = {};
    const std::int32_t since = zs[row];
    record(row, at, n, zero, zero, w);
    zs[row] = since;
  };
  auto contact_weights = [](const ContactRow& r) {
    return [&r](double* w) {
      w[0] = 1.0 / (r.inv_wn * r.inv_wn);
      w[1] = w[2] = w[3] = 1.0 / (r.inv_wt * r.inv_wt);
    };
  };

  // A visit that left a zero-impulse row unchanged; one that changed a row.
  auto stays_open = [&](auto& r, bool closed) {
    if (closed) ++t.active;
    else note_quiet(r, sweep, freeze);
  };
  auto unfreeze = [&](auto& r) {
    r.quiet = 0;
    r.frozen_until = 0;
    ++t.changed;
  };
  // Frozen rows are skipped by normal sweeps, and only they are solved by a check sweep.
  auto skip = [&](const auto& r) {
    if ((r.frozen_until > sweep) != check) {
      ++t.skipped;
      return true;
    }
    ++t.updates;
    return false;
  };

  auto contact = [&](ContactRow& r) {
    const std::size_t row = static_cast<std::size_t>(&r - C), at = 4 * row;
    if (skip(r)) {
      if (rec) record_zero(row, at, 4, contact_weights(r));
      return;
    }
    SolverBody& bi = B[r.i];
    SolverBody& bj = B[r.j];
    const Vec3 n = r.n;
    Vec3 vj = bj.v, wj = bj.w;
    if (r.image != 0) {  // a seam row: j's velocities seen from i's side
      vj = sec.rot(vj, 1);
      wj = sec.rot(wj, 1);
    }
    const Vec3 u = (vj - bi.v) - (r.rj * wj + r.ri * bi.w).cross(n);
    const double un = u.dot(n);
    double pn = r.pn - (un + r.bias) * r.inv_wn;
    Vec3 pt;
    ContactStatus status = ContactStatus::kOpen;
    if (!(pn > 0.0)) {
      pn = 0.0;
      pt.setZero();
    } else {
      pt = r.pt - r.inv_wt * (u - un * n);
      status = radial_return(pt, pn, r.mu);
    }
    const double dpn = pn - r.pn;
    const Vec3 dpt = pt - r.pt;
    r.status = status;
    const bool closed = r.bias <= 0.0;
    if (dpn == 0.0 && dpt.squaredNorm() == 0.0) {
      if (pn == 0.0) {  // open, stays open
        stays_open(r, closed);
        if (rec) record_zero(row, at, 4, contact_weights(r));
        return;
      }
    }
    unfreeze(r);
    r.pn = pn;
    r.pt = pt;
    const double wn = bi.inv_mass + bj.inv_mass;
    const double wt = wn + r.ri * r.ri * bi.inv_inertia + r.rj * r.rj * bj.inv_inertia;
    detail::apply_row_impulse(bi, bj, r.image, r.ri, r.rj, n, dpn * n + dpt, sec);
    t.dv2 += wn * wn * dpn * dpn + wt * wt * dpt.squaredNorm();
    t.wp2 += wn * wn * pn * pn + wt * wt * pt.squaredNorm();
    if (closed || pn != 0.0) ++t.active;
    if (rec) {
      const double f[4] = {dpn, dpt.x(), dpt.y(), dpt.z()};
      const double g[4] = {pn, pt.x(), pt.y(), pt.z()};
      const double w[4] = {wn * wn, wt * wt, wt * wt, wt * wt};
      record(row, at, 4, f, g, w);
    }
  };

  // The end of a rope or angle visit: λ is the new impulse, `closed` whether the
  // constraint is at or past its limit, w2 the squared residual weight, `apply(dλ)` puts
  // the change on the bodies; `at` its entry in the Anderson vectors.
  auto finish_scalar = [&](auto& r, std::size_t at, double lam, bool closed, double w2, auto&& apply) {
    const double dl = lam - r.lambda;
    if (rec) {
      const std::size_t row = at - 3 * contacts_.size();
      if (dl == 0.0 && lam == 0.0) record_zero(row, at, 1, [w2](double* w) { w[0] = w2; });
      else record(row, at, 1, &dl, &lam, &w2);
    }
    if (dl == 0.0 && lam == 0.0) {
      stays_open(r, closed);
      return;
    }
    unfreeze(r);
    r.lambda = lam;
    if (dl != 0.0) apply(dl);
    t.dv2 += w2 * dl * dl;
    t.wp2 += w2 * lam * lam;
    ++t.active;
  };

  auto rope = [&](RopeRow& r) {
    const std::size_t at = rec ? aa->ropes_at + static_cast<std::size_t>(&r - R) : 0;
    if (skip(r)) {
      if (rec) record_zero(at - 3 * contacts_.size(), at, 1, [&r](double* w) { w[0] = r.wb * r.wb; });
      return;
    }
    SolverBody& bi = B[r.i];
    SolverBody& bj = B[r.j];
    const double rate = r.image != 0 ? r.ej.dot(bj.v) - r.e.dot(bi.v) : r.e.dot(bj.v - bi.v);
    finish_scalar(r, at, std::max(0.0, r.lambda + (rate - r.bias) / r.wb), r.c <= 0.0, r.wb * r.wb,
                  [&](double dl) {
                    bi.v += (bi.inv_mass * dl) * r.e;
                    bj.v -= (bj.inv_mass * dl) * r.ej;
                  });
  };

  auto angle = [&](AngleRow& r) {
    const std::size_t at = rec ? aa->angles_at + static_cast<std::size_t>(&r - A) : 0;
    if (skip(r)) {
      if (rec) record_zero(at - 3 * contacts_.size(), at, 1, [&r](double* w) { w[0] = r.scale * r.scale * r.wa * r.wa; });
      return;
    }
    SolverBody& ba = B[r.a];
    SolverBody& bb = B[r.b];
    SolverBody& bc = B[r.c];
    const double rate = r.ga.dot(ba.v) + r.gb.dot(bb.v) + r.gc.dot(bc.v);
    finish_scalar(r, at, std::max(0.0, r.lambda - (rate + r.bias) / r.wa), r.ca <= 0.0,
                  r.scale * r.scale * r.wa * r.wa, [&](double dl) {
                    ba.v += (ba.inv_mass * dl) * r.ga;
                    bb.v += (bb.inv_mass * dl) * r.gb;
                    bc.v += (bc.inv_mass * dl) * r.gc;
                  });
  };

  if (forward) {
    for (int k : lists.contacts) contact(C[k]);
    for (int k : lists.ropes) rope(R[k]);
    for (int k : lists.angles) angle(A[k]);
  } else {
    for (auto it = lists.angles.rbegin(); it != lists.angles.rend(); ++it) angle(A[*it]);
    for (auto it = lists.ropes.rbegin(); it != lists.ropes.rend(); ++it) rope(R[*it]);
    for (auto it = lists.contacts.rbegin(); it != lists.contacts.rend(); ++it) contact(C[*it]);
  }
  out = t;
  if (rec)
    for (int h = 0; h < m; ++h) {
      sums[h] = hsum[h];
      sums[m + h] = bsum[h];
    }
}

// Anderson acceleration (Options::anderson_depth; type II, Walker & Ni 2011). A recording
// sweep (sweep_lists) stores each row's F = G − P_in and G, the new difference column and
// the partial dot products; the m × m least-squares solve runs on one thread
// (detail::anderson_solve); anderson_apply then sets P̃ = G − Σ γ ΔG per row, projected on
// the constraints, and applies P̃ − G to the bodies, so P̃ is the next sweep's input. The
// weights D are the residual's (W_n², W_t², W_b², (ℓ W_a)²): the combination minimises the
// norm the stopping test measures.
void World::anderson_begin(detail::Anderson& a) {
  a.m = opt_.anderson_depth;
  a.ropes_at = 4 * contacts_.size();
  a.angles_at = a.ropes_at + ropes_.size();
  a.stride = a.angles_at + angles_.size();
  a.buf.swap(aa_buf_);
  a.buf.resize(a.stride * static_cast<std::size_t>(2 + 2 * a.m));
  a.part.assign(lists_.size() * static_cast<std::size_t>(2 * a.m), 0.0);
  a.zero_since.assign(contacts_.size() + ropes_.size() + angles_.size(), detail::Anderson::kNever);
  a.iter = 0;
  std::fill(std::begin(a.last_push), std::end(a.last_push), 0);
  a.best = a.best_step = std::numeric_limits<double>::infinity();
}

void World::anderson_apply(const RowLists& lists, detail::Anderson& a, int sweep) {
  const double* dg[10];
  double gam[10];
  int nh = 0;
  for (int j = 0; j < a.count; ++j) {
    if (a.gamma[j] == 0.0) continue;
    dg[nh] = a.dG(j);
    gam[nh++] = a.gamma[j];
  }
  if (nh == 0) return;
  // A row quiet since before every held column was written has zeros in them: P̃ = G = 0.
  std::int32_t quiet_below = detail::Anderson::kNever;
  for (int j = 0; j < a.count; ++j) quiet_below = std::min(quiet_below, a.last_push[j] - 1);
  const std::int32_t* const zs = a.zero_since.data();
  const std::size_t nc = contacts_.size();
  // Σ γ ΔG at entry i.
  auto shift = [&](std::size_t i) {
    double v = 0.0;
    for (int h = 0; h < nh; ++h) v += gam[h] * dg[h][i];
    return v;
  };
  // A row frozen for the next sweep keeps G (zero impulse).
  SolverBody* const B = body_.data();
  const detail::Sector sec(opt_);
  for (int k : lists.contacts) {
    if (zs[k] <= quiet_below) continue;
    ContactRow& r = contacts_[static_cast<std::size_t>(k)];
    if (r.frozen_until > sweep + 1) continue;
    const std::size_t at = 4 * static_cast<std::size_t>(k);
    double pn = r.pn - shift(at);
    Vec3 pt;
    if (!(pn > 0.0)) {
      pn = 0.0;
      pt.setZero();
    } else {
      pt = r.pt - Vec3(shift(at + 1), shift(at + 2), shift(at + 3));
      (void)radial_return(pt, pn, r.mu);
    }
    const double dpn = pn - r.pn;
    const Vec3 dpt = pt - r.pt;
    if (dpn != 0.0 || dpt.squaredNorm() != 0.0) {
      r.quiet = 0;
      r.pn = pn;
      r.pt = pt;
      apply_contact(r, dpn * r.n + dpt, sec);
    }
  }
  // A rope or angle row (`row` its index among all rows, `at` its vector entry): λ̃ ≥ 0,
  // `apply(dλ)` puts the change on the bodies.
  auto scalar = [&](auto& r, std::size_t row, std::size_t at, auto&& apply) {
    if (zs[row] <= quiet_below || r.frozen_until > sweep + 1) return;
    const double p = std::max(0.0, r.lambda - shift(at));
    const double dl = p - r.lambda;
    if (dl == 0.0) return;
    r.quiet = 0;
    r.lambda = p;
    apply(dl);
  };
  for (int k : lists.ropes) {
    const std::size_t i = static_cast<std::size_t>(k);
    RopeRow& r = ropes_[i];
    scalar(r, nc + i, a.ropes_at + i, [&](double dl) {
      B[r.i].v += (B[r.i].inv_mass * dl) * r.e;
      B[r.j].v -= (B[r.j].inv_mass * dl) * r.ej;
    });
  }
  for (int k : lists.angles) {
    const std::size_t i = static_cast<std::size_t>(k);
    AngleRow& r = angles_[i];
    scalar(r, nc + ropes_.size() + i, a.angles_at + i, [&](double dl) {
      B[r.a].v += (B[r.a].inv_mass * dl) * r.ga;
      B[r.b].v += (B[r.b].inv_mass * dl) * r.gb;
      B[r.c].v += (B[r.c].inv_mass * dl) * r.gc;
    });
  }
}

namespace detail {

/// The stopping logic of one step's sweeps, shared by the serial and the threaded loop.
/// Sweep `sweep` (1-based) is forward when odd. A sweep that meets the tolerance with
/// frozen rows skipped is followed by a check sweep over the frozen rows only: the step
/// has converged when none of them changes (the state is then the one the residual was
/// measured on); otherwise the changed rows are unfrozen and the normal sweeps go on.
/// The check sweeps count as sweeps.
struct SweepControl {
  SweepControl(const Options& o, StepDiagnostics& diag, std::size_t parts, double roundoff_dv)
      : opt(o), d(diag), part(parts), roundoff(roundoff_dv) {}
  const Options& opt;
  StepDiagnostics& d;
  std::vector<SweepTotals> part;  ///< per slab, then the rows across slabs
  bool check = false;             ///< the next sweep is a check sweep
  bool was_check = false;         ///< the sweep just finished was a check sweep
  Anderson* aa = nullptr;         ///< acceleration scratch (anderson_depth > 0)
  double roundoff = 0.0;          ///< a sweep correction √Σ|WΔP|² at or below this is round-off (m/s)
  bool converged = false;
  int iterations = 0;
  double residual = 0.0;

  /// Sums the parts of sweep `sweep`; true when the sweeps stop (converged or the cap).
  bool finish_sweep(int sweep) {
    SweepTotals sum;
    for (const SweepTotals& p : part) {  // fixed order: deterministic
      sum.dv2 += p.dv2;
      sum.wp2 += p.wp2;
      sum.updates += p.updates;
      sum.active += p.active;
      sum.skipped += p.skipped;
      sum.changed += p.changed;
    }
    d.row_updates += sum.updates;
    d.active_row_updates += sum.active;
    iterations = sweep;
    was_check = check;
    if (check) {
      check = false;
      if (sum.changed == 0) {
        converged = true;
        return true;
      }
    } else {
      d.frozen_skips += sum.skipped;
      residual = sum.wp2 > 0.0 ? std::sqrt(sum.dv2 / sum.wp2)
                               : (sum.dv2 > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
      if (residual <= opt.tolerance || std::sqrt(sum.dv2) <= roundoff) {
        if (sum.skipped == 0) {
          converged = true;
          return true;
        }
        check = true;
      }
    }
    return sweep >= opt.max_iterations;
  }
};

/// Anderson bookkeeping before a recording sweep (one thread): the slot of the new
/// difference column, when the previous sweep left F and G.
void anderson_before(Anderson& a) {
  ++a.iter;
  a.skip_below = a.iter - 1;  // quiet at the previous recording sweep: F and G are zeros
  if (a.have_prev) {
    a.push = (a.newest + 1) % a.m;
    a.newest = a.push;
    a.count = std::min(a.count + 1, a.m);
    // ... and the slot's old content is zero if it was quiet when the slot was last written
    a.skip_below = std::min(a.skip_below, a.last_push[a.push] - 1);
    a.last_push[a.push] = a.iter;
  } else {
    a.push = -1;
  }
}

void anderson_solve(Anderson& a, std::size_t parts);

/// After a sweep that did not stop the step (one thread): true when the impulses are to
/// be extrapolated (γ set). No extrapolation after a check sweep (F and G not recorded:
/// the columns restart), before one (it must see the state the residual was measured
/// on), and when the residual grew past twice the best since the last restart (the
/// extrapolation went astray: the columns restart). A step whose residual has not
/// reached a new low for kAndersonStall sweeps goes on with plain NLGS (the extrapolation
/// can cycle where rows switch between open and closed; NLGS then still converges).
constexpr int kAndersonStall = 50;
bool anderson_after(Anderson& a, const SweepControl& c, std::size_t parts) {
  if (a.off) return false;
  if (c.residual < a.best_step) {
    a.best_step = c.residual;
    a.since_best = 0;
  } else if (++a.since_best >= kAndersonStall) {
    a.off = true;
    return false;
  }
  auto restart = [&] {
    a.count = 0;
    a.newest = -1;
    a.best = c.residual;
  };
  if (c.was_check) {
    restart();
    a.have_prev = false;
    return false;
  }
  a.have_prev = true;
  if (c.check) return false;
  if (!(c.residual <= 2.0 * a.best)) {
    restart();
    return false;
  }
  a.best = std::min(a.best, c.residual);
  if (a.push < 0) return false;
  anderson_solve(a, parts);
  for (int j = 0; j < a.count; ++j)
    if (a.gamma[j] != 0.0) return true;
  return false;
}

/// The coefficients γ (one thread, after the gathers): the partial sums added in part
/// order (deterministic), the new Gram row stored, then (ΔFᵀDΔF + ε tr I) γ = ΔFᵀD F
/// with ε = 1e-10 against nearly dependent columns. γ = 0 (plain NLGS) without columns
/// or when the solve is not finite.
void anderson_solve(Anderson& a, std::size_t parts) {
  std::fill(std::begin(a.gamma), std::end(a.gamma), 0.0);
  const int m = a.m, n = a.count;
  double row[10] = {}, rhs[10] = {};
  for (std::size_t p = 0; p < parts; ++p) {
    const double* s = a.part.data() + p * static_cast<std::size_t>(2 * m);
    for (int j = 0; j < n; ++j) {
      row[j] += s[j];
      rhs[j] += s[m + j];
    }
  }
  for (int j = 0; j < n; ++j) a.H[a.push][j] = a.H[j][a.push] = row[j];
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 10, 10>;  // on the stack
  using SmallVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 10, 1>;
  Small M(n, n);
  SmallVec b(n);
  double trace = 0.0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) M(i, j) = a.H[i][j];
    b(i) = rhs[i];
    trace += a.H[i][i];
  }
  if (!(trace > 0.0)) return;
  M.diagonal().array() += 1e-10 * trace;
  const SmallVec g = M.ldlt().solve(b);
  if (!g.allFinite()) return;
  for (int j = 0; j < n; ++j) a.gamma[j] = g(j);
}

}  // namespace detail

void World::sweep_serial(detail::SweepControl& c) {
  detail::Anderson* const aa = c.aa;
  for (int sweep = 1;; ++sweep) {
    c.part[0] = SweepTotals{};
    detail::Anderson* const rec = aa && !c.check && !aa->off ? aa : nullptr;
    sweep_lists(lists_[0], !opt_.alternate_sweeps || sweep % 2 == 1, sweep, c.check, c.part[0], rec,
                rec ? rec->part.data() : nullptr);
    if (c.finish_sweep(sweep)) break;
    if (aa) {
      if (detail::anderson_after(*aa, c, 1)) anderson_apply(lists_[0], *aa, sweep);
      if (!c.check) detail::anderson_before(*aa);
    }
  }
}

// Slabs in parallel, then the rows across slabs on one thread (before the slabs in
// backward sweeps). Two to three barriers per sweep: OpenMP's own barriers put a waiting
// thread to sleep after a short spin, and the wake-up costs milliseconds on a virtual
// machine (measured: 15 000 beads, 2 threads, 0.9 s per step against 0.1 s serial), so
// the sweep loop synchronises through a spinning barrier (SpinBarrier) instead.
void World::sweep_parallel(detail::SweepControl& c, int rows) {
  const int T = opt_.threads;
  bool stop = false, extrapolate = false;
  const std::size_t boundary = static_cast<std::size_t>(T);
  detail::Anderson* const aa = c.aa;
  const std::size_t width = aa ? static_cast<std::size_t>(2 * aa->m) : 0;
  auto sums = [&](detail::Anderson* rec, std::size_t part) { return rec ? rec->part.data() + part * width : nullptr; };
  SpinBarrier barrier;
  // Small problems run the same slabs on one thread (the same bits: the slabs share no
  // body), since waking the pool each step costs more than the sweep saves there.
  const int workers =
      static_cast<std::int64_t>(rows) >= static_cast<std::int64_t>(opt_.parallel_min_rows_per_thread) * T ? T : 1;
#pragma omp parallel num_threads(workers)
  {
#pragma omp single
    barrier.reset(omp_get_num_threads());
    const int nthreads = omp_get_num_threads();
    const int me = omp_get_thread_num();
    for (int sweep = 1;; ++sweep) {
      const bool forward = !opt_.alternate_sweeps || sweep % 2 == 1;
      detail::Anderson* const rec = aa && !c.check && !aa->off ? aa : nullptr;
      if (!forward) {
        if (me == 0) sweep_lists(lists_[boundary], false, sweep, c.check, c.part[boundary], rec, sums(rec, boundary));
        barrier.wait();
      }
      for (int s = me; s < T; s += nthreads) {
        const std::size_t p = static_cast<std::size_t>(s);
        sweep_lists(lists_[p], forward, sweep, c.check, c.part[p], rec, sums(rec, p));
      }
      barrier.wait();
      if (me == 0) {
        if (forward) sweep_lists(lists_[boundary], true, sweep, c.check, c.part[boundary], rec, sums(rec, boundary));
        stop = c.finish_sweep(sweep);
        extrapolate = false;
        if (!stop && aa) {
          extrapolate = detail::anderson_after(*aa, c, boundary + 1);
          if (!c.check) detail::anderson_before(*aa);
        }
      }
      barrier.wait();
      if (stop) break;
      if (extrapolate) {  // the slabs, then the rows across them (they share bodies)
        for (int s = me; s < T; s += nthreads) anderson_apply(lists_[static_cast<std::size_t>(s)], *aa, sweep);
        barrier.wait();
        if (me == 0) anderson_apply(lists_[boundary], *aa, sweep);
        barrier.wait();
      }
    }
  }
}

namespace {

/// Rows (one kind) into the order of the lists' `member` lists, then those in no list;
/// the lists renumbered to match, row_of[p] the own index of the row now at p, `remap`
/// applied to each row's body indices. The own-order rows are kept in `own`.
template <class Row, class Remap>
void to_list_order(std::vector<Row>& rows, std::vector<Row>& own, std::vector<int>& row_of,
                   std::vector<detail::RowLists>& lists, std::vector<int> detail::RowLists::*member, Remap&& remap) {
  row_of.clear();
  std::vector<char> listed(rows.size(), 0);
  for (detail::RowLists& l : lists)
    for (int& k : l.*member) {
      listed[static_cast<std::size_t>(k)] = 1;
      row_of.push_back(k);
      k = static_cast<int>(row_of.size()) - 1;
    }
  for (std::size_t k = 0; k < rows.size(); ++k)
    if (listed[k] == 0) row_of.push_back(static_cast<int>(k));
  own.resize(rows.size());
  for (std::size_t p = 0; p < rows.size(); ++p) {
    own[p] = rows[static_cast<std::size_t>(row_of[p])];
    remap(own[p]);
  }
  rows.swap(own);
}

/// The inverse: each row back to its own index, `keep(own, row)` restoring the own
/// row's body indices in it.
template <class Row, class Keep>
void to_own_order(std::vector<Row>& rows, std::vector<Row>& own, const std::vector<int>& row_of, Keep&& keep) {
  for (std::size_t p = 0; p < rows.size(); ++p) {
    Row& o = own[static_cast<std::size_t>(row_of[p])];
    keep(o, rows[p]);
    o = rows[p];
  }
  rows.swap(own);
}

}  // namespace

// Threads > 1: the sweeps run on copies of the bodies and rows stored slab by slab, so
// that each thread streams its own part of memory. In the bodies' own order the slabs
// of a poured packing interleave (every other body, on the cup), and although a body
// and a row each fill whole cache lines, the threads then share lines through the
// prefetchers' neighbouring lines: measured on the 2 700-bead shallow cup, two threads
// took 1.6x one thread's time per sweep with equal work each. The copies keep each
// list's rows in order and each row's arithmetic, so the result is bit-identical to the
// sweeps on the own order.
void World::to_slab_order() {
  const std::size_t n = x_.size(), T = static_cast<std::size_t>(opt_.threads);
  // Bodies: slab by slab, in their own order within a slab; the wall sentinels (n + s)
  // stay where they are.
  std::vector<std::size_t> start(T + 1, 0);
  for (std::size_t b = 0; b < n; ++b) ++start[static_cast<std::size_t>(slab_[b]) + 1];
  for (std::size_t s = 0; s < T; ++s) start[s + 1] += start[s];
  slab_pos_.resize(body_.size());
  own_body_.resize(body_.size());
  for (std::size_t b = 0; b < n; ++b) slab_pos_[b] = static_cast<int>(start[static_cast<std::size_t>(slab_[b])]++);
  for (std::size_t b = n; b < body_.size(); ++b) slab_pos_[b] = static_cast<int>(b);
  for (std::size_t b = 0; b < body_.size(); ++b) own_body_[static_cast<std::size_t>(slab_pos_[b])] = body_[b];
  body_.swap(own_body_);
  auto pos = [&](int b) { return slab_pos_[static_cast<std::size_t>(b)]; };
  // Rows: in the order of the lists, then those in no list (ropes and angles that are
  // not live), so that every row keeps its entries of the Anderson vectors.
  own_lists_ = lists_;
  to_list_order(contacts_, own_contacts_, contact_of_, lists_, &RowLists::contacts, [&](ContactRow& r) {
    r.i = pos(r.i);
    r.j = pos(r.j);
  });
  to_list_order(ropes_, own_ropes_, rope_of_, lists_, &RowLists::ropes, [&](RopeRow& r) {
    r.i = pos(r.i);
    r.j = pos(r.j);
  });
  to_list_order(angles_, own_angles_, angle_of_, lists_, &RowLists::angles, [&](AngleRow& r) {
    r.a = pos(r.a);
    r.b = pos(r.b);
    r.c = pos(r.c);
  });
}

void World::from_slab_order() {
  for (std::size_t b = 0; b < body_.size(); ++b) own_body_[b] = body_[static_cast<std::size_t>(slab_pos_[b])];
  body_.swap(own_body_);
  // Each row back to its own place, with its own body indices.
  to_own_order(contacts_, own_contacts_, contact_of_, [](const ContactRow& o, ContactRow& r) {
    r.i = o.i;
    r.j = o.j;
  });
  to_own_order(ropes_, own_ropes_, rope_of_, [](const RopeRow& o, RopeRow& r) {
    r.i = o.i;
    r.j = o.j;
  });
  to_own_order(angles_, own_angles_, angle_of_, [](const AngleRow& o, AngleRow& r) {
    r.a = o.a;
    r.b = o.b;
    r.c = o.c;
  });
  lists_.swap(own_lists_);
}

// Stage 4: nonlinear Gauss-Seidel sweeps until the tolerance or max_iterations.
void World::solve(StepDiagnostics& d) {
  bool any_rows = false;
  for (const RowLists& l : lists_) any_rows = any_rows || !l.contacts.empty() || !l.ropes.empty() || !l.angles.empty();
  if (!any_rows) return;
  detail::SweepControl c(opt_, d, static_cast<std::size_t>(opt_.threads) + 1, roundoff_dv_);
  detail::Anderson aa;
  if (opt_.anderson_depth > 0) {
    anderson_begin(aa);
    detail::anderson_before(aa);
    c.aa = &aa;
  }
  if (opt_.threads == 1) {
    sweep_serial(c);
  } else {
    to_slab_order();
    sweep_parallel(c, d.rows);
    from_slab_order();
  }
  if (c.aa) aa_buf_.swap(aa.buf);
  if (!c.converged) {
    d.hit_iteration_cap = true;
    ++cap_hits_;
  }
  d.iterations = c.iterations;
  d.residual = c.residual;
}

}  // namespace shearzone::sim
