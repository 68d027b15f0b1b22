// shearzone/sim/world.hpp: the contact-dynamics engine (non-smooth contact dynamics,
// Moreau–Jean θ = 1) for rigid spheres, half-space walls and bead-chain constraints.
// References: M. Jean, Comput. Methods Appl. Mech. Eng. 177, 235 (1999); J. J. Moreau, in
// Nonsmooth Mechanics and Applications, CISM 302 (Springer, 1988);
// the model and its validations in docs/sim.md.
//
// Model, one step of length h (SI units throughout):
//  1. Contact detection at the positions x(t) through a uniform cell grid: every
//     sphere pair with at least one mobile sphere, and every mobile sphere–wall pair,
//     whose gap g = |x_j − x_i| − (d_i + d_j)/2 is below the alert distance
//     δ = 2 (v_max + |g| h) h + margin becomes a contact row.
//  2. Free velocities: v ← v + h g for mobile spheres (implicit Euler, θ = 1).
//  3. Warm start: every row that existed in the previous step (contacts matched by body
//     pair, rope and angle rows by index) starts from its previous impulse (the
//     tangential impulse projected on the new tangent plane) and applies it.
//  4. Nonlinear Gauss–Seidel sweeps over all rows, alternately forward and backward:
//     contacts by the exact closed form of src/sim/local_solve.hpp, ropes (tension only,
//     |x_j − x_i| ≤ L_max through the centres) and turning-angle limits (exact three-body
//     row). Each visit applies its impulse change at once.
//     Stopping test (LMGC90's QuadDV in non-dimensional form): after a sweep
//     r = √Σ|W ΔP|² / √Σ|W P| (velocity corrections made by the sweep over the velocity
//     the impulses carry; an angle row is scaled by its mean bond length), converged
//     when r ≤ tolerance, or when the corrections are round-off, √Σ|W ΔP|² ≤ 64 ε v with
//     v the fastest sphere's speed plus |g| h (a packing whose impulses are all ~0 else
//     cycles in the last bits: r = 1e-4 from λ changes of 1e-23 N s, measured on a
//     swinging chain). Hitting max_iterations is counted.
//     Freezing ("contact freezing"): a row without impulse whose local solve left it
//     unchanged on two consecutive visits, with a positive gap (or a slack rope, an angle
//     below its limit), is skipped for the next `freeze_sweeps` sweeps. A sweep that meets
//     the tolerance with rows skipped is followed by a check sweep over the frozen rows
//     only; the step ends when none of them changes (so a converged step satisfies every
//     row), otherwise the changed rows are unfrozen and the sweeps go on. The freeze
//     state restarts with every step (nothing to checkpoint).
//     Threads (`threads` = T > 1): the bodies are split into T slabs along the longest
//     axis of the mobile bodies' bounding box (at the quantiles of their coordinate);
//     rows whose bodies all lie in one slab are swept by that slab's thread, in parallel;
//     the rows across slabs are swept by one thread after them (before them in backward
//     sweeps). Deterministic for a fixed T (a different T is a different Gauss–Seidel
//     order: same tolerance, other bits).
//     Optionally (anderson_depth > 0) every sweep is followed by an Anderson
//     extrapolation over the last sweeps, projected on the constraints (see Options).
//  5. Positions: x ← x + h v⁺ for mobile and kinematic spheres; orientations
//     q ← exp(h ω⁺/2) q (unit quaternions, renormalised).
//  6. Diagnostics and divergence checks on the new state (see StepDiagnostics); a
//     violation throws NoResultError naming the step and the bodies.
//
// Periodic sector (Options::sectors = k ≥ 3): the world holds one wedge of a system with
// k-fold symmetry about a vertical axis (a cup with a k-blade vane). R is the rotation by
// 2π/k about that axis (exact for k = 4: x, y → −y, x). A body near the wedge's first
// side is also seen, rotated by R, beyond its second side (an image); contact rows
// between a body and an image of another ("seam rows", ContactRecord::image = 1) see the
// image's velocity rotated and give it the impulse rotated back, so both sides meet
// exactly the rows they would meet in the whole system. Ropes and angle rows join a bead
// to the image of its neighbour where the chain crosses a side (the image offset of each
// row follows the beads). A mobile sphere whose centre leaves the wedge is moved to its
// image inside (position, velocity, spin and orientation rotated) at the end of the step,
// and the warm start of its contact rows is dropped for that step. Fixed and kinematic
// spheres must stay inside (a rotor's axis must be the sector's); a sphere within its own
// radius of the axis is its own image (a vane's hub, shared by every sector).
//
// Impulses are P = h·R (N s); a rope's λ/h is its tension (N); an angle row's λ is an
// impulse·length (N s m). Consecutive beads of a chain keep their ordinary frictional
// contact row besides the rope row (bond length in [d, L_max]).
// Determinism: fixed row order; the same inputs and thread count give bit-identical
// states.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace shearzone::sim {

using Vec3 = Eigen::Vector3d;

/// State of a contact after its local solve (see ContactInfo).
enum class ContactStatus : std::uint8_t { kOpen, kSticking, kSliding };

enum class BodyKind : std::uint8_t {
  kMobile,     ///< integrated by the engine
  kFixed,      ///< never moves, v = ω = 0 (wall beads)
  kKinematic,  ///< prescribed v and ω (e.g. vane beads); moved by x ← x + h v
};

/// Half-space wall: spheres live on the side the unit normal points to.
struct Wall {
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();  ///< normalised by add_wall
  double friction = 0.5;        ///< Coulomb μ between the wall and a sphere
};

struct Options {
  double time_step = 1e-3;                ///< h (s)
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);   ///< (m/s²)
  double friction = 0.5;                  ///< sphere–sphere Coulomb μ
  double tolerance = 1e-4;                ///< NLGS residual r (non-dimensional)
  int max_iterations = 1000;              ///< NLGS sweep cap per step
  double alert_margin = 0.02;             ///< margin added to 2 v_max h, × smallest diameter
  double max_overlap = 0.05;              ///< divergence: overlap / d
  double max_rope_excess = 0.05;          ///< divergence: (|x_j − x_i| − L_max) / d
  double max_angle_excess = 0.034906585039886591;  ///< divergence: θ − θ_max (rad), 2°
  int freeze_sweeps = 16; ///< sweeps a quiet zero-impulse row is skipped (0: never freeze)
  int threads = 1;        ///< sweep threads (slabs); 1 = serial
  /// Sweep order: forward and backward in turn (true, the classic symmetric NLGS) or
  /// always forward (false; under shear fewer sweeps to the tolerance, see docs/sim.md).
  bool alternate_sweeps = true;
  /// Anderson acceleration of the sweeps (type II, this many columns; 0: plain NLGS).
  /// After every sweep that does not stop the step, the impulses become the combination
  /// of the last sweeps' outputs that best cancels their residuals, projected back on the
  /// constraints (P_n ≥ 0, |P_t| ≤ μ P_n, λ ≥ 0) and applied to the bodies. The stopping
  /// test is unchanged (a sweep's own change r ≤ tolerance, after which no extrapolation
  /// follows), so an accelerated step meets the same criterion as NLGS. In [0, 10].
  int anderson_depth = 0;
  /// With threads > 1, the slabs run on one thread when the step has fewer rows than this
  /// times `threads` (waking the pool costs more than it saves there). The result is the
  /// same bits either way (the slabs share no body); not stored in checkpoints.
  int parallel_min_rows_per_thread = 2000;
  /// Periodic sector (0: none). k ≥ 3: the world is the wedge of azimuth
  /// [sector_start, sector_start + 2π/k) about the vertical axis through sector_centre
  /// (its z ignored) of a k-fold symmetric system; the wedge's two sides are periodic
  /// (see "Periodic sector" above). In {0} ∪ [3, 64].
  int sectors = 0;
  Vec3 sector_centre = Vec3::Zero();  ///< a point of the sector's axis (m; z unused)
  double sector_start = 0.0;          ///< azimuth of the wedge's first side (rad, from +x towards +y)
};

/// True when the centre x lies in the wedge of a periodic sector (always true without
/// one): azimuth about the axis in [sector_start, sector_start + 2π/k), or on the axis.
[[nodiscard]] bool sector_contains(const Options& options, const Vec3& x);

/// One step's diagnostics (the future diagnostics CSV row).
struct StepDiagnostics {
  std::int64_t step = 0;          ///< 1-based index of the step just done
  int iterations = 0;             ///< NLGS sweeps
  double residual = 0.0;          ///< final r
  bool hit_iteration_cap = false;  ///< r > tolerance after max_iterations sweeps
  int contacts = 0;               ///< contact rows (within the alert distance)
  int active_contacts = 0;        ///< P_n > 0
  int sliding_contacts = 0;       ///< active and on the Coulomb cone
  int sticking_contacts = 0;      ///< active and inside the cone
  int active_ropes = 0;           ///< λ > 0
  int active_angles = 0;          ///< λ > 0
  double max_overlap = 0.0;       ///< max over contact rows of −g/d after the step (≥ 0)
  double max_rope_excess = 0.0;   ///< max (|x_j − x_i| − L_max)/d after the step (≥ 0)
  double max_angle_excess = 0.0;  ///< max θ − θ_max (rad) after the step (≥ 0)
  double kinetic_energy = 0.0;    ///< Σ ½ m v² + ½ I ω² over mobile spheres (J)
  /// Row updates: local solves done in this step's sweeps. Frozen rows skipped by a sweep
  /// and rows that cannot act (a rope or angle row without a mobile body, the
  /// straight-chain guard) do not count.
  std::int64_t row_updates = 0;
  /// Active row updates: the row updates on rows in contact or loaded, i.e. whose impulse
  /// is non-zero after the local solve or whose constraint is closed (contact gap ≤ 0, rope
  /// taut |x_j − x_i| ≥ L_max, angle row at or past θ_max).
  std::int64_t active_row_updates = 0;
  std::int64_t frozen_skips = 0;  ///< row visits skipped because the row was frozen
  int rows = 0;                   ///< rows of this step (contacts + ropes + angles)
};

/// A rigid rotor (the vane): kinematic spheres that turn together about the axis through
/// `centre` along `axis` by φ(t) = phi0 sin(2π f (t − t_start) + phase), t = step × h
/// (exact, no accumulated time). Each sphere sits exactly at c + R(φ(t)) (x₀ − c), its
/// orientation R(φ(t)) q₀ (never x ← x + h v, which spirals outwards); during the step
/// from t to t + h it moves with the chord velocity (x(t + h) − x(t))/h and spins with
/// (φ(t + h) − φ(t))/h about the axis, the rigid rotation's Ω × r to O(h²), so the
/// contact solve sees the displacement the sphere really makes. φ > 0 is a right-handed
/// rotation about `axis` (counter-clockwise seen from the +axis side).
struct Rotor {
  std::vector<int> bodies;
  std::vector<Vec3> reference;                         ///< x₀ of each body (φ = 0), m
  std::vector<Eigen::Quaterniond> reference_orientation;  ///< q₀ of each body (φ = 0)
  Vec3 centre = Vec3::Zero();                          ///< a point of the axis, m
  Vec3 axis = Vec3::UnitZ();                           ///< unit
  double phi0 = 0.0;                                   ///< amplitude, rad
  double f_Hz = 0.0;                                   ///< frequency (0: at rest, φ = phi0 sin(phase))
  double phase = 0.0;                                  ///< rad
  double t_start = 0.0;                                ///< time origin of the drive, s
  /// φ at time t (rad).
  [[nodiscard]] double angle(double t) const;
};

/// A contact row of the last step, for tests and force analysis. The impulse P acts on
/// body_j, −P on body_i (or on the wall); the normal points from i (or the wall) to j.
struct ContactRecord {
  int body_i = -1;  ///< −1 for a wall contact
  int wall = -1;    ///< wall index for a wall contact, else −1
  int body_j = -1;
  Vec3 normal = Vec3::UnitZ();
  double gap = 0.0;             ///< at the start of the step (m)
  double normal_impulse = 0.0;  ///< P_n (N s)
  Vec3 tangential_impulse = Vec3::Zero();
  ContactStatus status = ContactStatus::kOpen;
  /// Periodic sector: 1 when body_j is seen through its image R x_j (a seam row; normal,
  /// gap and impulses are then those of body_i's side), else 0.
  int image = 0;
};

/// The complete state of a World (checkpoint/restart):
/// World::state() exports it and World::from_state() rebuilds a World that continues
/// bit-identically (one thread). Masses and inertias are stored as such (not recomputed
/// from a density); the contact rows are the warm-start rows of the last step in their
/// order, with their raw statuses. The cell grid is rebuilt every step and holds no state.
struct WorldState {
  struct Rope {
    int i = 0, j = 0;
    double max_length = 0.0;
    double impulse = 0.0;  ///< λ of the last step (N s)
    int image = 0;         ///< periodic sector: j seen from i as R^image x_j (−1..1)
  };
  struct Angle {
    int prev = 0, mid = 0, next = 0;
    double max_angle = 0.0;
    double impulse = 0.0;  ///< λ of the last step (N s m)
    int image_prev = 0, image_next = 0;  ///< periodic sector: prev and next seen as R^k x (k in −1..1)
  };
  Options options;
  std::int64_t step = 0;
  std::int64_t iteration_cap_hits = 0;
  std::vector<Vec3> position, velocity, angular_velocity;
  std::vector<Eigen::Quaterniond> orientation;  ///< unit quaternions (body to world)
  std::vector<double> diameter, mass, inertia;
  std::vector<BodyKind> kind;
  std::vector<Wall> walls;  ///< normals as stored (unit)
  std::vector<Rope> ropes;
  std::vector<Angle> angles;
  std::vector<ContactRecord> contacts;  ///< last step's rows, raw status
  std::vector<Rotor> rotors;
};

/// `state` to be continued at the time step h (World::from_state): every stored impulse
/// (contacts, ropes, angles; an impulse is h times a force) scaled by h over the state's
/// step, so that the warm start stays the same forces; the options' time_step set to h.
[[nodiscard]] WorldState at_time_step(WorldState state, double h);

// The solver's rows and scratch, private to the engine (src/sim/solver_rows.hpp).
namespace detail {
struct SolverBody;
struct ContactRow;
struct ContactInfo;
struct PreviousContact;
struct RopeRow;
struct AngleRow;
struct RowLists;
struct SweepTotals;
struct SweepControl;
struct Anderson;
struct Sector;
}  // namespace detail

class World {
 public:
  /// Throws ConfigError for an option out of range.
  explicit World(const Options& options);
  World(const World&);
  World(World&&) noexcept;
  World& operator=(const World&);
  World& operator=(World&&) noexcept;
  ~World();

  /// Adds a sphere; returns its index. Mass ρ π d³/6, moment of inertia m d²/10.
  /// Throws ConfigError for a non-finite position or a non-positive diameter/density.
  int add_sphere(const Vec3& position, double diameter, double density,
                 BodyKind kind = BodyKind::kMobile);
  /// Adds a half-space wall; returns its index.
  int add_wall(const Wall& wall);
  /// Rope row: |x_j − x_i| ≤ max_length (= d + l_max), tension only, through the centres.
  int add_rope(int i, int j, double max_length);
  /// Turning-angle row at `mid`: angle between x_mid − x_prev and x_next − x_mid ≤ max_angle.
  int add_angle_limit(int prev, int mid, int next, double max_angle);
  /// Ropes between consecutive beads (max bond length) and, if max_angle < π, angle
  /// rows at every interior bead.
  void add_chain(std::span<const int> beads, double max_bond_length, double max_angle);

  /// Makes the kinematic spheres `bodies` a rigid rotor (see Rotor) with the drive
  /// (phi0, f_Hz, phase, t_start); their present positions and orientations are taken
  /// as the rotor's at the present time (x₀ = c + R(−φ(now)) (x − c)). Returns its index.
  /// Throws ConfigError for a body that is not kinematic or already in a rotor, a zero
  /// axis or a non-finite value.
  int add_rotor(std::span<const int> bodies, const Vec3& centre, const Vec3& axis, double phi0, double f_Hz,
                double phase = 0.0, double t_start = 0.0);
  /// A new drive for rotor r from now on (amplitude branches): the spheres keep their
  /// reference x₀ and are moved to φ(now) of the new drive at once.
  void set_rotor_drive(int r, double phi0, double f_Hz, double phase, double t_start);
  [[nodiscard]] int rotor_count() const { return static_cast<int>(rotors_.size()); }
  [[nodiscard]] const Rotor& rotor(int r) const { return rotors_.at(static_cast<std::size_t>(r)); }
  /// φ of rotor r now (rad).
  [[nodiscard]] double rotor_angle(int r) const;
  /// The motor torque about the rotor's axis over the last step (N m): what the drive
  /// must exert to impose the motion against the contact forces of the spheres on it,
  /// Σ over its contact rows of ((p − c) × P_on_beads)·axis / h, p the contact point at
  /// the start of the step. τ > 0 drives towards +φ. 0 before the first step.
  [[nodiscard]] double rotor_torque(int r) const;

  /// Initial conditions of a mobile sphere, or the prescribed motion of a kinematic one.
  /// Throws ConfigError for a fixed sphere or a non-finite value.
  void set_velocity(int body, const Vec3& v);
  void set_angular_velocity(int body, const Vec3& omega);

  /// Advances one step. Throws NoResultError on divergence (non-finite state, overlap,
  /// rope excess or angle excess above the thresholds), naming the step and the bodies.
  StepDiagnostics step();

  [[nodiscard]] const Options& options() const { return opt_; }
  [[nodiscard]] int body_count() const { return static_cast<int>(x_.size()); }
  [[nodiscard]] const Vec3& position(int b) const { return x_.at(static_cast<std::size_t>(b)); }
  [[nodiscard]] const Vec3& velocity(int b) const;
  [[nodiscard]] const Vec3& angular_velocity(int b) const;
  /// Orientation (body frame to world), identity at creation.
  [[nodiscard]] const Eigen::Quaterniond& orientation(int b) const {
    return q_.at(static_cast<std::size_t>(b));
  }
  [[nodiscard]] double diameter(int b) const { return 2.0 * radius_.at(static_cast<std::size_t>(b)); }
  [[nodiscard]] double mass(int b) const { return mass_.at(static_cast<std::size_t>(b)); }
  [[nodiscard]] double inertia(int b) const { return inertia_.at(static_cast<std::size_t>(b)); }
  [[nodiscard]] BodyKind kind(int b) const { return kind_.at(static_cast<std::size_t>(b)); }
  [[nodiscard]] const std::vector<Wall>& walls() const { return walls_; }

  /// Contact rows of the last step with their final impulses.
  [[nodiscard]] std::vector<ContactRecord> contacts() const;
  [[nodiscard]] int rope_count() const;
  [[nodiscard]] int angle_count() const;
  /// λ of a rope row in the last step (N s); tension = λ/h.
  [[nodiscard]] double rope_impulse(int r) const;
  /// λ of an angle row in the last step (N s m).
  [[nodiscard]] double angle_impulse(int a) const;

  [[nodiscard]] std::int64_t steps_done() const { return step_; }
  [[nodiscard]] std::int64_t iteration_cap_hits() const { return cap_hits_; }
  [[nodiscard]] double time() const { return static_cast<double>(step_) * opt_.time_step; }

  /// The complete state (see WorldState).
  [[nodiscard]] WorldState state() const;
  /// Rebuilds a World from a state. Throws ConfigError for inconsistent sizes, a body
  /// index out of range, a non-finite value or an option out of range.
  [[nodiscard]] static World from_state(const WorldState& state);

  /// FNV-1a (64 bit) over the bit patterns of the step count, every position, velocity
  /// and angular velocity, and every row's key and impulses.
  [[nodiscard]] std::uint64_t state_hash() const;

 private:
  using SolverBody = detail::SolverBody;
  using ContactRow = detail::ContactRow;
  using ContactInfo = detail::ContactInfo;
  using PreviousContact = detail::PreviousContact;
  using RopeRow = detail::RopeRow;
  using AngleRow = detail::AngleRow;
  using RowLists = detail::RowLists;
  using SweepTotals = detail::SweepTotals;

  [[nodiscard]] const SolverBody& body_at(int b) const;
  void check_body(int b, const char* what) const;
  [[nodiscard]] ContactRecord record(std::size_t k) const;  // contact row k, raw status
  // The stages of step(), in order (model 1-6 above).
  double contact_search_distance(std::int64_t step);  // 1: δ, wall sentinels, step-size refusals
  void find_contacts(double alert);                   // 1: the contact rows
  void add_free_velocities();                          // 2
  void prepare_rows();                                 // 3: row geometry and warm start
  void partition_rows();                               // 3: sweep lists (slabs)
  void solve(StepDiagnostics& d);                      // 4: NLGS to the tolerance or the cap
  void sweep_serial(detail::SweepControl& control);
  void sweep_parallel(detail::SweepControl& control, int rows);
  void to_slab_order();    // 4, threads > 1: bodies and rows stored slab by slab
  void from_slab_order();  // 4: back to the bodies' and rows' own order
  void sweep_lists(const RowLists& lists, bool forward, int sweep, bool check, SweepTotals& out,
                   detail::Anderson* aa = nullptr, double* sums = nullptr);
  void apply_contact(const ContactRow& r, const Vec3& p, const detail::Sector& sec);
  void anderson_begin(detail::Anderson& a);  // sizes the scratch
  void anderson_apply(const RowLists& lists, detail::Anderson& a, int sweep);
  void integrate_positions();                          // 5
  void wrap_sector();                                  // 5: mobile spheres back into a periodic sector
  [[nodiscard]] int nearest_image(int i, int j) const;  // k of the R^k x_j nearest x_i (periodic sector)
  void drive_rotors();                                 // 1: rotor velocities for this step
  void place_rotors();                                 // 5: rotor spheres at their exact place
  void rotor_torques();                                // 4: motor torque of each rotor
  void remember_impulses();                            // 6: warm start of the next step
  void check_state(StepDiagnostics& d) const;          // 6: diagnostics, divergence checks

  Options opt_;
  // Bodies: positions and orientations, solver view (+ sentinels), properties.
  std::vector<Vec3> x_;
  std::vector<Eigen::Quaterniond> q_;
  std::vector<SolverBody> body_;
  std::vector<double> radius_, mass_, inertia_;
  std::vector<BodyKind> kind_;
  std::vector<Wall> walls_;
  std::vector<ContactRow> contacts_;
  std::vector<ContactInfo> info_;
  std::vector<PreviousContact> previous_;
  std::vector<RopeRow> ropes_;
  std::vector<AngleRow> angles_;
  // Sweep order: lists_[t] for slab t, lists_.back() for the rows across slabs.
  std::vector<RowLists> lists_;
  std::vector<int> slab_;  // slab of each body (threads > 1)
  // The solve's slab-ordered copies (threads > 1): body b at slab_pos_[b]; the rows in
  // the order of lists_ (slab 0, 1, …, the boundary), each holding its index in the own
  // order (row_of_); the own-order arrays wait in the second of each pair.
  std::vector<int> slab_pos_;
  std::vector<SolverBody> own_body_;
  std::vector<ContactRow> own_contacts_;
  std::vector<RopeRow> own_ropes_;
  std::vector<AngleRow> own_angles_;
  std::vector<int> contact_of_, rope_of_, angle_of_;
  std::vector<RowLists> own_lists_;
  std::vector<double> aa_buf_;  // Anderson scratch, kept between steps (no state)
  double roundoff_dv_ = 0.0;    // this step's round-off floor of a sweep's correction (m/s)
  // Cell-grid scratch; the periodic sector's images (body, position) in the grid.
  std::vector<int> cell_of_, cell_start_, cell_bodies_;
  std::vector<int> ghost_of_;
  std::vector<Vec3> ghost_x_;
  std::vector<std::int8_t> wrapped_;  // per body: wedges it was moved back by this step
  std::int64_t step_ = 0;
  std::int64_t cap_hits_ = 0;
  std::vector<Rotor> rotors_;
  std::vector<int> rotor_of_;           // rotor of each body, −1 for none
  std::vector<double> rotor_torque_;    // motor torque of each rotor, last step (N m)
};

}  // namespace shearzone::sim
