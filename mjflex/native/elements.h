// Elements of a MuJoCo model and their evaluation on an mjData: the loop every path shares
// (the engine plugin, the mjcb_passive dispatcher and Python's queries through ctypes).

#ifndef MJFLEX_NATIVE_ELEMENTS_H_
#define MJFLEX_NATIVE_ELEMENTS_H_

#include <mujoco/mujoco.h>

#include "flexure_math.h"

// what mjfx_evaluate does (bits)
#define MJFX_APPLY 1    // add the generalized forces to qfrc
#define MJFX_WRENCH 2   // out6[e] = wrench on body B [moment; force], world axes, the moment about site b with a
                        // rest pose, else about frame b*'s origin (site b within the sites' rounding)
#define MJFX_ENERGY 4   // out1[e] = elastic energy (the end stops' included)
#define MJFX_POWER 8    // out1[e] = dissipated power (damping B and the stops' damping)
#define MJFX_COORDS 16  // out6[e] = finite twist of frame b relative to frame a

// One element, laid out once, for both forms, by instances.c (mjfx_read_element): in the plugin's
// init for an instance, and for Python (mjfx_read_table) for a text record. Python mirrors this
// struct as a numpy dtype whose offsets it reads from mjfx_element_field
// (mjflex/native/library.py), so the two cannot drift apart.
typedef struct mjfxElement_ {
  // read at every evaluation (first, together: a few cache lines)
  int site_a, site_b, body_a, body_b;
  int method, enabled, viscous;
  int offset;  // the rest offset is not the identity
  int free_a, free_b;                          // dof address of a free joint of a child of the world, or -1
  int chain_a0, chain_a1, chain_b0, chain_b1;  // ranges into the chain of dofs that move each body
  int terms_lo, terms_hi, terms_top;           // rows of the terms' tables, largest exponent
  int kstruct, bstruct;                        // MJFX_FULL / MJFX_DIAGONAL / MJFX_ZERO of K and B
  int stops;                                   // the element has end stops (stop_lo, stop_hi, stop_k)
  int stop_damped;                             // and they are damped (stop_b not all zero)
  int rest;                                    // a rest pose is composed into the rest offset (R0, p0)
  double qa[4];        // site a's orientation in body A (the model's site_quat)
  double qb[4];        // site b's orientation in body B, times the rest offset's inverse (mjfx_element_prepare)
  double p0[3];        // rest offset: position of frame b* in frame a at qpos0 (residual, then rest pose)
  double lever_a[3];   // origin of frame a in body A (site a's position; mjfx_element_prepare)
  double lever_b[3];   // origin of frame b* in body B: site b's position - R(qb) p0 (mjfx_element_prepare)
  double inv_mass;     // largest 1/mass of the element's (non-world) bodies [1/kg]
  double inv_inertia;  // largest 1/(principal inertia) [1/(kg m^2)]
  double kdiag[6];     // diagonals of K and B (mjfx_element_prepare)
  double bdiag[6];
  // read when K or B are not diagonal
  double K[36];        // stiffness in the element frame, row-major (planar: embedded)
  double B[36];        // damping, same layout (zero without damping)
  double R0[9];        // rest offset: orientation of frame b* in frame a at qpos0 (row-major)
  // read when the element has end stops (mjflex.core.stops): limits of the stop coordinates
  // [rx, ry, rz, x, y, z] (-inf / +inf: none; planar elements on rz, x, y), their stiffness and
  // their damping (active beyond a limit only; 0 where there is no limit)
  double stop_lo[6];
  double stop_hi[6];
  double stop_k[6];
  double stop_b[6];
} mjfxElement;

// What an evaluation found for divergence reporting: the first element whose wrench is not
// finite, and the element whose wrench alone implies the largest acceleration of its bodies.
typedef struct mjfxScan_ {
  int nonfinite;      // index of the first element with a non-finite wrench, or -1
  int largest;        // index of the element with the largest implied acceleration, or -1
  double accel;       // that acceleration [m/s^2 or rad/s^2]
} mjfxScan;

// Evaluate elements el[0..n) on d (kinematics and velocities of the last mj_forward).
// chain: dof chains; exps/coefs: the terms' tables (rows terms_lo..terms_hi of an element).
// Disabled elements give zeros; MuJoCo's spring/damper disable flags switch off the elastic
// and viscous parts. Returns -1, or the index of the first element with a non-finite wrench
// (then APPLY has stopped there; the caller decides what to do with qfrc).
int mjfx_evaluate(const mjModel* m, const mjData* d, const mjfxElement* el, int n, const int* chain,
                  const int* exps, const double* coefs, int mode, double* qfrc, double* out6, double* out1,
                  mjfxScan* scan);

// mjfx_evaluate evaluates consecutive elements of one kind together, one per lane of the CPU's
// vectors: 2 lanes (SSE2 on x86-64) with GNU C, 4 (AVX) where the compiler is GCC on x86-64 and
// the CPU has AVX, 1 with other compilers; the choice is made at the first evaluation. Every
// choice gives the same bits (flexure_kernel.h). mjfx_set_lanes(0) picks the widest available,
// 2 or 4 forces one (for the tests); it returns the previous choice (0: none yet), or -1 if that
// many lanes are not available. mjfx_lanes: the lanes in use (1, 2 or 4).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(MJFX_SCALAR)
#define MJFX_HAVE_AVX_BUILD 1
#else
#define MJFX_HAVE_AVX_BUILD 0
#endif
int mjfx_set_lanes(int lanes);
int mjfx_lanes_available(int lanes);
int mjfx_lanes(void);

// Pose (R0, p0) of frame b seen from frame a (R_a^T R_b, R_a^T (p_b - p_a)), its distance [m] and angle [rad].
void mjfx_relative_offset(const double Ra[9], const double pa[3], const double Rb[9], const double pb[3],
                          double R0[9], double p0[3], double* dist, double* angle);

// Rest offset (R0, p0) of site b seen from site a in d (at qpos0), its distance [m] and angle [rad].
void mjfx_rest_offset(const mjData* d, int sa, int sb, double R0[9], double p0[3], double* dist, double* angle);

// Whether (R0, p0) is exactly the identity.
int mjfx_offset_is_identity(const double R0[9], const double p0[3]);

// Compose an element's rest pose (pos, unit quaternion quat: the pose of frame b in frame a at which its
// energy is zero) into its measured rest offset (R0, p0: the rounding residual of the sites at qpos0):
// (R0, p0) <- X_rest X_res, i.e. frame b* = frame b X_res^-1 X_rest^-1: the residual is removed from
// frame b first (it belongs to the site's placement), then the rest pose, which is thus exact in frame a.
void mjfx_compose_rest(const double pos[3], const double quat[4], double R0[9], double p0[3]);

// Fill an element's derived fields from its sites, rest offset, K and B: offset, qa, qb, lever_a,
// lever_b, kstruct, bstruct, kdiag, bdiag.
void mjfx_element_prepare(const mjModel* m, mjfxElement* e);

// Summed lengths [m] of the site and body positions that place sites sa and sb (the scale of
// the coincidence tolerance, MJFX_COINCIDENCE_RTOL).
double mjfx_length_scale(const mjModel* m, int sa, int sb);

// Largest inverse mass and inverse principal inertia of the element's non-world bodies.
void mjfx_inverse_inertia(const mjModel* m, int ba, int bb, double* inv_mass, double* inv_inertia);

// Dof address of a free joint that is the only joint of a child of the world, else -1.
int mjfx_free_dofadr(const mjModel* m, int body);

// Dofs whose motion moves body (its own last dof to the root) into out (capacity m->nv);
// returns their number.
int mjfx_dof_chain(const mjModel* m, int body, int* out);

//------------------------------------------------------------------------------ divergence watch

// Per-mjData record of what the elements did recently, for the divergence reports: MuJoCo's
// bad-state counters as last seen, the element with the largest implied acceleration in the
// last step, and per element how often it diverged in this run (see mjfx_watch_judge).
typedef struct mjfxTally_ {
  int count;          // divergences of the element in this run
  int bad;            // the first one: MuJoCo's check that fired (0 qpos, 1 qvel, 2 qacc), -1 non-finite wrench
  double time;        // start of the step of the first one [s]
  double accel;       // the first one's implied acceleration
  double last;        // start of the step of the last one counted [s]
  long last_run;      // the watch's reset count when it was counted (with last: one event counts once)
} mjfxTally;

typedef struct mjfxWatch_ {
  int seen[3];         // BADQPOS, BADQVEL, BADQACC counters at the last look
  int reset;           // a reset since the last look (plugin: MuJoCo's reset callback)
  int started;         // last_time is known
  int cand;            // element with the largest implied acceleration recently, or -1
  double last_time;    // d->time of the last evaluation
  double step_start;   // start of the step the last evaluation belongs to
  double cand_accel, cand_time, cand_step;
  long resets;         // resets seen (MuJoCo's automatic ones too): tells repeats at equal times apart
  long cand_resets;    // resets when the candidate was found
  int n;               // number of tallies
  int exact;           // steps are marked by mjfx_watch_step_end (the plugin), resets by the flag
  mjfxTally tally[];   // n of them
} mjfxWatch;

// bytes of a watch with n tallies
size_t mjfx_watch_size(int n);
void mjfx_watch_clear(mjfxWatch* w, int n);

// What a judgement asks the caller to report.
typedef struct mjfxVerdict_ {
  int element;      // -1: nothing to report
  int first;        // first divergence of the element in this run (print it)
  int nonfinite;    // the wrench was not finite (else: MuJoCo found a bad state)
  double accel;     // implied acceleration (huge-force case)
  double step;      // start of the step [s]
  int bad;          // which of MuJoCo's checks fired: 0 qpos, 1 qvel, 2 qacc, -1 none
} mjfxVerdict;

// Look at MuJoCo's bad-state counters before an evaluation (or in the plugin's advance): if
// MuJoCo judged a step bad since the last look, the recent candidate element is the culprit
// (verdict filled, tallied when commit). A reset with zero counters starts a new run.
void mjfx_watch_judge(mjfxWatch* w, const mjModel* m, const mjData* d, int commit, mjfxVerdict* v);

// Record an evaluation's scan at d->time: a new candidate, or a non-finite element (verdict).
void mjfx_watch_record(mjfxWatch* w, const mjModel* m, const mjData* d, const mjfxScan* scan, int commit,
                       mjfxVerdict* v);

// Mark the end of a step (the plugin's advance): the next step starts at d->time.
void mjfx_watch_step_end(mjfxWatch* w, const mjData* d);

// Report a verdict through MuJoCo: mju_warning with auto-reset on or in a thread without an
// error handler, mju_error otherwise (a Python FatalError, a Batch SimulationError). Only the
// first divergence of an element in a run is printed as a warning; errors are always raised.
// element/model names are plain text.
void mjfx_report(const mjModel* m, const mjfxVerdict* v, const char* element);

// The report's text (what mjfx_report prints), for Python's dispatcher; returns its length.
int mjfx_report_text(const mjModel* m, const mjfxVerdict* v, const char* element, char* buf, int size);

// Whether a MuJoCo error in the calling thread would be caught (not end the process), and
// whether mjfx_report would raise (1) or warn (0) for this model in this thread.
int mjfx_errors_caught_here(void);
int mjfx_report_raises(const mjModel* m);

#endif  // MJFLEX_NATIVE_ELEMENTS_H_
